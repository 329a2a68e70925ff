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
    """One panel per field, drawn by :meth:`cgbound.Result.plot`: profiles (every component a line named in
    the legend) on a grid with one resolved axis, maps (the field, |vector| or the largest singular value
    of a tensor, equal aspect, labelled colorbar) with two. Labels carry units or "(simulation units)"."""
    import matplotlib
    if matplotlib.get_backend().lower() not in ("agg", "pdf", "svg", "cairo") and not os.environ.get("DISPLAY"):
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(fields)
    if len(result.grid.resolved) == 1:
        fig, axes = plt.subplots(1, n, figsize=(3.6 * n, 4.4), sharey=True, squeeze=False, constrained_layout=True)
    else:
        fig, axes = plt.subplots(1, n, figsize=(5.2 * n, 4.2), squeeze=False, constrained_layout=True)
    for ax, name in zip(axes[0], fields):
        result.plot(name, ax=ax)
    return fig
