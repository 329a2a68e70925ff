"""Estimate the memory a request needs and refuse, before allocating, one that cannot fit.

The estimate counts doubles per evaluation node: the primary sums kept at once,
the C core's per-thread copies of the output of one scatter (the core gives each
of its ``n_threads - 1`` extra threads a private copy of the output array, except
on grids it cuts into slabs, where the threads write to the output itself), the
derived fields and one temporary. Good enough to turn a hopeless request into a
clear MemoryError instead of a crash or swapping; with slabs it counts copies
that are not made.
"""
import os

from ._threads import get_num_threads

#: doubles per node of each primary sum (also the width of the scatter that makes it), as powers of D
PRIMARY_RANK = {"rho": 0, "p_w": 1, "k": 2, "sk": 2, "b": 1, "phi": 0, "sb": 2, "sw": 2, "sx": 2, "t": 1}

#: primaries summed over the flowing particles' positions, in one scatter
POSITION_PRIMARIES = ("rho", "p_w", "k", "b", "phi")

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


def per_node_doubles(needed, fields, field_ranks, dim, threads, frames=1, time_average="mean", n_times=1):
    """Doubles per node held at the peak of a coarse-graining request."""
    prim = sum(dim ** PRIMARY_RANK[p] for p in needed)
    # the primaries of the particle positions are summed in one scatter (fields.compute_primaries)
    batched = sum(dim ** PRIMARY_RANK[p] for p in needed if p in POSITION_PRIMARIES)
    widest = max([dim ** PRIMARY_RANK[p] for p in needed if p not in POSITION_PRIMARIES] + [batched])
    scratch = dim if "sk" in needed else 0                  # node velocities for the fluctuation sum
    out = sum(dim ** field_ranks[f] for f in fields)
    widest_field = max((dim ** field_ranks[f] for f in fields), default=0)
    one_frame = prim + scratch + (threads - 1) * widest + out + widest_field + batched
    if time_average == "mean" and frames > 1:
        # running sums, their mean and the velocity spread, beside one frame's primaries
        return one_frame + 2 * prim + (dim * dim if "sk" in needed else 0)
    if time_average == "none":
        return one_frame + 2 * frames * out                 # every frame's fields, then the stacked copy
    if time_average == "smooth":
        return one_frame + frames * prim + 2 * prim + 2 * n_times * out
    return one_frame


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
