"""Figures written by the command line: the format from the file's extension (PNG, PDF or SVG)."""
import os

from .errors import UsageError

FORMATS = {".png": "png", ".pdf": "pdf", ".svg": "svg"}


def figure_format(path, flag):
    """The matplotlib format of ``path`` from its extension, checked before any work."""
    ext = os.path.splitext(path)[1].lower()
    if ext not in FORMATS:
        raise UsageError(flag, f"expected a file name ending in {', '.join(FORMATS)} (the format follows the "
                               f"extension), got {path!r}")
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise UsageError(flag, f"directory {directory!r} does not exist")
    return FORMATS[ext]


def check_matplotlib(flag):
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise UsageError(flag, "writing a figure needs matplotlib: pip install matplotlib") from None


def save_figure(fig, path, fmt):
    """Write ``fig`` to ``path`` atomically in format ``fmt`` (vector formats stay vector)."""
    from .._atomic import atomic_write
    options = {"dpi": 150} if fmt == "png" else {}
    atomic_write(path, lambda tmp: fig.savefig(tmp, format=fmt, **options), suffix=os.path.splitext(path)[1])


def fields_figure(result, fields):
    """One panel per field: profiles (every component as a line) on a grid with one resolved axis,
    maps (the field, |vector| or the largest singular value of a tensor) with two."""
    import matplotlib
    if matplotlib.get_backend().lower() not in ("agg", "pdf", "svg", "cairo") and not os.environ.get("DISPLAY"):
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .. import plot
    from ..fields import FIELDS
    resolved = result.grid.resolved
    n = len(fields)
    if len(resolved) == 1:
        fig, axes = plt.subplots(1, n, figsize=(3.6 * n, 4.4), sharey=True, squeeze=False, constrained_layout=True)
        names = result.box.axis_names
        dim = result.grid.dim
        for ax, name in zip(axes[0], fields):
            rank = FIELDS[name][0]
            if rank == 0:
                plot.profile(result, name, ax=ax, label=name)
            elif rank == 1:
                for a in range(dim):
                    plot.profile(result, name, component=names[a], ax=ax, label=f"{name}_{names[a]}")
            else:
                for a in range(dim):
                    for b in range(a, dim):
                        plot.profile(result, name, component=names[a] + names[b], ax=ax,
                                     label=f"{name}_{names[a]}{names[b]}")
            ax.set_xlabel(f"{name} (simulation units)")
            if rank:
                ax.legend(fontsize=7)
        return fig
    fig, axes = plt.subplots(1, n, figsize=(5.2 * n, 4.2), squeeze=False, constrained_layout=True)
    for ax, name in zip(axes[0], fields):
        plot.field_map(result, name, ax=ax)
        ax.set_aspect("equal")
    return fig
