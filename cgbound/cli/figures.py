"""Figures written by the command line: the format from the file's extension (PNG, PDF or SVG)."""
import os

from .errors import UsageError


def figure_format(path, flag):
    """The matplotlib format of ``path`` from its extension, checked before any work."""
    from ..plot import figure_format as format_of
    try:
        fmt = format_of(path)
    except ValueError as exc:
        raise UsageError(flag, str(exc).split(": ", 1)[1]) from None
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise UsageError(flag, f"directory {directory!r} does not exist")
    return fmt


def check_matplotlib(flag):
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise UsageError(flag, "writing a figure needs matplotlib: pip install matplotlib") from None


def save_figure(fig, path, fmt):
    """Write ``fig`` to ``path`` atomically in the format of its extension (``fmt``, checked before the work)."""
    from ..plot import save_figure as save
    save(fig, path)


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
