"""Plots of coarse-grained fields (matplotlib is imported only when a plot is made).

* :func:`plot` -- what :meth:`cgbound.Result.plot` draws: a profile or a map, chosen by the grid.
* :func:`profile` -- depth profiles like the paper's Fig. 3 (any component of any field).
* :func:`field_map` -- 2-D maps like Fig. 1: |t| for vectors, the largest singular value for tensors.
* :func:`particles` -- discs of a 2-D snapshot drawn over a map, fixed ones marked with a cross.
* :func:`save_figure` -- write a figure in the format of the file's extension (PNG, PDF, SVG), atomically.
* :func:`field_label` -- a field's axis label: symbol, sign convention and unit, e.g.
  "$-\\sigma_{zz}$ (compression) [m g / d²]", or "(simulation units)" when the units are not known.

Every function draws into ``ax`` when given (a panel of a grid of subplots) and returns the Axes.
"""
import os

import numpy as np

from ._atomic import atomic_write
from .fields import FIELDS, STRESS_FIELDS, field_shape
from .grid import Grid
from .units import label_units

#: field -> (mathtext symbol, whether a subscript needs parentheses around it)
SYMBOLS = {
    "density": (r"\rho", False),
    "momentum": (r"\rho V", True),
    "velocity": ("V", False),
    "momentum_flux": (r"\rho \langle v v \rangle", True),
    "kinetic_stress": (r"\sigma^{k}", False),
    "contact_stress": (r"\sigma^{c}", False),
    "boundary_stress": (r"\sigma^{b}", False),
    "interaction_force_density": ("t", False),
    "body_force_density": ("b", False),
    "stress": (r"\sigma", False),
    "extended_stress": (r"\sigma'", False),
    "volume_fraction": (r"\phi", False),
    "pressure": ("p", False),
    "temperature": ("T", False),
}


#: figure formats by file extension: vector formats stay vector
FIGURE_FORMATS = {".png": "png", ".pdf": "pdf", ".svg": "svg"}


def figure_format(path, name="path"):
    """The matplotlib format of ``path`` from its extension (``.png``, ``.pdf``, ``.svg``), else ValueError."""
    ext = os.path.splitext(os.fspath(path))[1].lower()
    if ext not in FIGURE_FORMATS:
        raise ValueError(f"{name}: expected a file name ending in {', '.join(FIGURE_FORMATS)} (the format follows "
                         f"the extension), got {os.fspath(path)!r}")
    return FIGURE_FORMATS[ext]


def save_figure(fig, path, dpi=150):
    """Write ``fig`` to ``path`` in the format of its extension (PNG at ``dpi``; PDF and SVG as vectors),
    through a temporary file, so an existing file is replaced only by a complete one. Returns the path."""
    fmt = figure_format(path)
    options = {"dpi": dpi} if fmt == "png" else {}
    return atomic_write(os.fspath(path), lambda tmp: fig.savefig(tmp, format=fmt, **options),
                        suffix=os.path.splitext(os.fspath(path))[1])


def _pyplot():
    try:
        import matplotlib.pyplot as plt
    except ImportError as exc:
        raise ImportError("plotting needs matplotlib: pip install matplotlib") from exc
    return plt


def field_symbol(name, component=None, convention="tension", dim=3):
    """The field's symbol in matplotlib mathtext with its sign convention: ``$\\sigma_{zz}$ (tension
    positive)``, ``$-\\sigma_{zz}$ (compression)``, ``$|V|$``, ``$\\|\\sigma\\|$ (largest singular
    value)``; ``component=None`` on a vector or tensor means its norm. Unknown fields use their name."""
    rank = len(field_shape(name, dim)) if name in FIELDS else 0
    base, parens = SYMBOLS.get(name, (r"\mathrm{" + name.replace("_", r"\_") + "}", False))
    if rank and component is None:
        return f"$|{base}|$" if rank == 1 else f"$\\|{base}\\|$ (largest singular value)"
    text = base if not component else (f"({base})_{{{component}}}" if parens else f"{base}_{{{component}}}")
    if name in STRESS_FIELDS:
        return f"$-{text}$ (compression)" if convention == "compression" else f"${text}$ (tension positive)"
    if name == "pressure":
        return f"${text}$ (compression positive)"
    return f"${text}$"


def field_rank_in(result, name):
    """Indices per node of field ``name`` in the result's dimension (a pseudo-vector index has none in 2D)."""
    return len(field_shape(name, result.box.dim))


def field_label(result, name, component=None):
    """Axis or colorbar label of a field: symbol, sign convention, unit (or "(simulation units)")."""
    return f"{field_symbol(name, component, result.convention, result.box.dim)} {label_units(name, result.units, result.box.dim)}"


def length_label(result, axis):
    """Label of a coordinate axis: its name and the length unit (``"z [d]"``, ``"x (simulation units)"``)."""
    return f"{axis} {label_units('length', result.units, result.box.dim)}"


def norm(result, name):
    """Scalar view of a field: the value, ``|v|`` for vectors, and for tensors the paper's
    ``|sigma| = max_{|x|=1} |sigma x|`` (the largest singular value; the largest ``|eigenvalue|`` when
    sigma is symmetric; frictional contacts make the contact stress asymmetric)."""
    value = result[name]
    rank = field_rank_in(result, name)
    if rank == 0:
        return value
    if rank == 1:
        return np.linalg.norm(value, axis=-1)
    return np.linalg.svd(value, compute_uv=False)[..., 0]


def _component(result, name, component):
    value = result[name]
    rank = field_rank_in(result, name)
    if rank == 0 or component is None:
        return value if rank == 0 else norm(result, name)
    axes = result.box.axis_names
    idx = tuple(axes.index(c) for c in component)
    if len(idx) != rank:
        raise ValueError(f"component: expected {rank} axis letters for {name}, got {component!r}")
    return value[(Ellipsis,) + idx]


def _components(result, name):
    """The components a profile draws as axis letters: each of a vector, the upper triangle (xx, xz, zz,
    ...) of a tensor."""
    names = result.box.axis_names
    rank = field_rank_in(result, name)
    if rank == 0:
        return [None]
    if rank == 1:
        return list(names)
    return [a + b for k, a in enumerate(names) for b in names[k:]]


def profile(result, name, component=None, axis=None, ax=None, **plot_kwargs):
    """Plot a field along the one resolved axis of a profile grid (e.g. ``component="zz"``).

    The profile is drawn with the field on the horizontal axis and depth on the vertical, like the
    paper's Fig. 3. The line's label is the field's symbol (a legend names every line); the horizontal
    axis says symbol, sign convention and unit. Returns the matplotlib Axes.
    """
    plt = _pyplot()
    grid = result.grid
    if not isinstance(grid, Grid) or len(grid.resolved) != 1:
        raise ValueError("result: profile() needs a grid with exactly one resolved axis")
    d = grid.resolved[0]
    coord = grid.axis_coordinates[d]
    values = np.asarray(_component(result, name, component))
    values = values.reshape(values.shape[:values.ndim - len(grid.shape)] + (-1,)) if values.ndim > len(grid.shape) else values.reshape(-1)
    if ax is None:
        _, ax = plt.subplots(figsize=(4, 5), constrained_layout=True)
    label = plot_kwargs.pop("label", field_symbol(name, component, result.convention))
    ax.plot(values.reshape(-1, coord.size).T if values.ndim > 1 else values, coord, label=label, **plot_kwargs)
    ax.set_ylabel(length_label(result, result.box.axis_names[d]))
    ax.set_xlabel(field_label(result, name, component))
    return ax


def plot(result, name, component=None, ax=None, **kwargs):
    """A profile (one resolved axis) or a map (two) of field ``name`` (see :meth:`cgbound.Result.plot`).

    On a profile with ``component=None``, a vector or tensor is drawn as one line per component with a
    legend naming each, and the horizontal axis gives the unit. Returns the Axes."""
    if name not in result:
        raise ValueError(f"field: expected one of the computed fields {', '.join(result.fields)}, got {name!r}")
    grid = result.grid
    resolved = len(grid.resolved) if isinstance(grid, Grid) else None
    if resolved == 1:
        if component is not None or field_rank_in(result, name) == 0:
            ax = profile(result, name, component, ax=ax, **kwargs)
        else:
            for comp in _components(result, name):
                # the legend names the component; the axis label says the convention once
                line = field_symbol(name, comp, result.convention, result.box.dim).split(" (")[0]
                ax = profile(result, name, comp, ax=ax, **dict(kwargs, label=kwargs.get("label", line)))
            ax.set_xlabel(f"{field_symbol(name, 'ij' if field_rank_in(result, name) == 2 else 'i', result.convention, result.box.dim)} "
                          f"{label_units(name, result.units, result.box.dim)}")
        if field_rank_in(result, name) and component is None:
            ax.legend(fontsize=7)
        return ax
    if resolved == 2:
        return field_map(result, name, component, ax=ax, **kwargs)
    raise ValueError(f"result: plot() draws results on a cg.Grid with one resolved axis (a profile) or two "
                     f"(a map), got {grid!r}")


def field_map(result, name, component=None, ax=None, cmap="viridis", colorbar=True, **imshow_kwargs):
    """Map of a field on a grid with two resolved axes: the component, or its norm (Fig. 1).

    Equal aspect (lengths are lengths), axes labelled with the length unit, and a colorbar labelled
    with the field's symbol, sign convention and unit. Returns the Axes."""
    plt = _pyplot()
    grid = result.grid
    if not isinstance(grid, Grid) or len(grid.resolved) != 2:
        raise ValueError("result: field_map() needs a grid with exactly two resolved axes")
    a, b = grid.resolved
    values = np.asarray(_component(result, name, component)).reshape([grid.shape[a], grid.shape[b]])
    lo, hi = grid.box.lower, grid.box.upper
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4), constrained_layout=True)
    im = ax.imshow(values.T, origin="lower", extent=(lo[a], hi[a], lo[b], hi[b]), cmap=cmap, **imshow_kwargs)
    ax.set_aspect("equal")
    names = result.box.axis_names
    ax.set_xlabel(length_label(result, names[a]))
    ax.set_ylabel(length_label(result, names[b]))
    ax.set_title(field_symbol(name, component, result.convention))
    if colorbar:
        ax.figure.colorbar(im, ax=ax, shrink=0.8, label=field_label(result, name, component))
    return ax


def thumbnail_png(result, size=(3.6, 2.6), dpi=80):
    """A small PNG of the result's first field (what Jupyter shows), or None if it cannot be drawn.

    Uses a bare matplotlib Figure (no pyplot), so showing a result draws nothing else in a notebook."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        return None
    grid = result.grid
    if not result.fields or not isinstance(grid, Grid) or len(grid.resolved) not in (1, 2):
        return None
    lead = result[result.fields[0]].ndim - len(grid.shape) - field_rank_in(result, result.fields[0])
    if lead:
        return None                       # a time axis: which frame to show is the user's choice
    import io
    fig = Figure(figsize=size, dpi=dpi, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    plot(result, result.fields[0], ax=ax)
    for axes in fig.axes:                 # the plot and its colorbar, if any
        for text in [axes.xaxis.label, axes.yaxis.label, axes.title]:
            text.set_fontsize(7)
        axes.tick_params(labelsize=6)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    return buffer.getvalue()


def particles(ax, snapshot, color="white", linewidth=0.8):
    """Draw the discs of a 2-D snapshot (radius from ``radii``), fixed ones marked with a cross."""
    plt = _pyplot()
    if snapshot.dim != 2:
        raise ValueError("snapshot: particles() draws 2-D snapshots")
    radii = snapshot.radii if snapshot.radii is not None else np.full(snapshot.n_particles, 0.5)
    for p, r, fixed in zip(snapshot.positions, radii, snapshot.fixed):
        ax.add_patch(plt.Circle(p, r, fill=False, color=color, lw=linewidth))
        if fixed:
            ax.plot(*p, "+", color=color, ms=6)
    return ax
