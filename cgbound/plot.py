"""Plots of coarse-grained fields (matplotlib is imported only when a plot is made).

* :func:`profile` -- depth profiles like the paper's Fig. 3 (any component of any field).
* :func:`field_map` -- 2-D maps like Fig. 1: |t| for vectors, max |eigenvalue| for tensors.
* :func:`particles` -- discs of a 2-D snapshot drawn over a map, fixed ones marked with a cross.
"""
import numpy as np

from .fields import FIELDS
from .grid import Grid


def _pyplot():
    try:
        import matplotlib.pyplot as plt
    except ImportError as exc:
        raise ImportError("plotting needs matplotlib: pip install matplotlib") from exc
    return plt


def norm(result, name):
    """Scalar view of a field: the value, ``|v|`` for vectors, and for tensors the paper's
    ``|sigma| = max_{|x|=1} |sigma x|`` (the largest singular value; the largest ``|eigenvalue|`` when
    sigma is symmetric; frictional contacts make the contact stress asymmetric)."""
    value = result[name]
    rank = FIELDS[name][0]
    if rank == 0:
        return value
    if rank == 1:
        return np.linalg.norm(value, axis=-1)
    return np.linalg.svd(value, compute_uv=False)[..., 0]


def _component(result, name, component):
    value = result[name]
    rank = FIELDS[name][0]
    if rank == 0 or component is None:
        return value if rank == 0 else norm(result, name)
    axes = result.box.axis_names
    idx = tuple(axes.index(c) for c in component)
    if len(idx) != rank:
        raise ValueError(f"component: expected {rank} axis letters for {name}, got {component!r}")
    return value[(Ellipsis,) + idx]


def profile(result, name, component=None, axis=None, ax=None, **plot_kwargs):
    """Plot a field along the one resolved axis of a profile grid (e.g. ``component="zz"``).

    The profile is drawn with the field on the horizontal axis and depth on the vertical,
    like the paper's Fig. 3. Returns the matplotlib Axes.
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
        _, ax = plt.subplots(figsize=(4, 5))
    label = plot_kwargs.pop("label", f"{name}{'_' + component if component else ''}")
    ax.plot(values.reshape(-1, coord.size).T if values.ndim > 1 else values, coord, label=label, **plot_kwargs)
    ax.set_ylabel(result.box.axis_names[d])
    ax.set_xlabel(label)
    return ax


def field_map(result, name, component=None, ax=None, cmap="viridis", colorbar=True, **imshow_kwargs):
    """Map of a field on a grid with two resolved axes: the component, or its norm (Fig. 1)."""
    plt = _pyplot()
    grid = result.grid
    if not isinstance(grid, Grid) or len(grid.resolved) != 2:
        raise ValueError("result: field_map() needs a grid with exactly two resolved axes")
    a, b = grid.resolved
    values = np.asarray(_component(result, name, component)).reshape([grid.shape[a], grid.shape[b]])
    lo, hi = grid.box.lower, grid.box.upper
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4))
    im = ax.imshow(values.T, origin="lower", extent=(lo[a], hi[a], lo[b], hi[b]), cmap=cmap, **imshow_kwargs)
    names = result.box.axis_names
    ax.set_xlabel(names[a])
    ax.set_ylabel(names[b])
    ax.set_title(name if component is None and FIELDS[name][0] == 0 else
                 f"{name} ({component})" if component else
                 f"|{name}|" if FIELDS[name][0] == 1 else f"max |eig {name}|")
    if colorbar:
        ax.figure.colorbar(im, ax=ax, shrink=0.8)
    return ax


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
