"""Refuse, before allocating, a request that cannot fit in memory; the threads the core will use.

The estimate of what a coarse graining needs is :func:`cgbound.pipeline.per_node_doubles`.
"""
import os

from ._threads import get_num_threads

GB = 1e9


def physical_memory():
    """Bytes of physical memory, or None where the platform does not say."""
    try:
        pages, size = os.sysconf("SC_PHYS_PAGES"), os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):
        return None
    if pages <= 0 or size <= 0:
        return None
    return pages * size


def core_threads(n_objects=None):
    """Threads the C core will use for a scatter over n_objects (1 without OpenMP)."""
    threads = get_num_threads()
    if n_objects is not None:
        threads = min(threads, max(int(n_objects), 1))
    return threads


def grid_doubles(shape):
    """Doubles a regular grid of ``shape`` holds itself: each axis's node coordinates (built in place)."""
    return sum(int(n) for n in shape)


def check_fits(name, nodes, doubles_per_node, what="the requested fields", extra_doubles=0):
    """Raise MemoryError naming ``name`` if nodes x doubles_per_node (+ extra_doubles) doubles exceed
    physical memory."""
    need = 8 * (int(nodes) * int(doubles_per_node) + int(extra_doubles))
    have = physical_memory()
    if have is not None and need > have:
        parts = [f"{int(nodes)} nodes x {int(doubles_per_node)} doubles for {what}"] if nodes else []
        if extra_doubles:
            parts.append(f"{int(extra_doubles)} doubles of the grid itself" + ("" if nodes else f", {what}"))
        size = f"{need / GB:.1f} GB" if need < 10 ** 300 else f"2**{need.bit_length()} bytes"
        raise MemoryError(f"{name}: expected a request that fits in memory, got one needing about {size} "
                          f"({' + '.join(parts)}) on a machine with "
                          f"{have / GB:.1f} GB of physical memory; use fewer nodes, fewer fields or average over axes")
    return need
