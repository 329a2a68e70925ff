"""Error bars on time averages from block means (``CoarseGrain(..., errors="blocks", n_blocks=B)``).

The frames of a run are cut into B consecutive blocks of (nearly) equal length; each block's
primaries are averaged and its fields derived like the run's (:class:`cgbound.averaging.Partial`
keeps one :class:`~cgbound.averaging.PrimaryAverage` per block). The standard error of a field at a
node is that of the mean of B block means,

    SE = sqrt( sum_k (F_k - mean F)^2 / (B (B - 1)) ),

which is honest when the block means are independent: blocks much longer than the correlation
time of the flow (Flyvbjerg & Petersen 1989). Whether they are is checked, not assumed: the lag-1
correlation of consecutive block means, r = sum_k (F_k - m)(F_{k+1} - m) / sum_k (F_k - m)^2, is
computed for every node and component with a spread, and a :class:`CorrelatedBlocksWarning` is
given when its median over them exceeds 2 / sqrt(B) (independent blocks give r ~ -1/B with a
spread of ~1/sqrt(B)): then the error bar is too small, and more frames (or fewer, longer blocks)
are needed. See docs/theory.md, "Error bars on time averages".
"""
import warnings

import numpy as np

from ._memory import check_fits
from .fields import derive, field_size, needed_primaries
from .primaries import PRIMARIES

#: the lag-1 correlation of consecutive block means, in units of 1/sqrt(n_blocks), above which a warning is given
CORRELATION_THRESHOLD = 2.0


class CorrelatedBlocksWarning(UserWarning):
    """Consecutive block means are correlated: the standard errors of the time average are too small."""


def block_assignment(indices, n_blocks):
    """{frame index: block number} cutting ``indices`` (in run order) into ``n_blocks`` consecutive blocks."""
    return {int(index): block for block, chunk in enumerate(np.array_split(np.asarray(indices), n_blocks))
            for index in chunk}


def check_block_memory(target, fields, dim, n_blocks):
    """Raise MemoryError naming ``n_blocks`` if the blocks' running sums and fields cannot fit (before any work)."""
    needed = needed_primaries(fields)
    per_block = (sum(dim ** PRIMARIES[p].rank for p in needed) + (dim * dim if "sk" in needed else 0)
                 + sum(field_size(f, dim) for f in fields))
    check_fits("n_blocks", target.size, n_blocks * per_block, what=f"the running sums and fields of {n_blocks} blocks")


def block_fields(partial):
    """The fields of every error block of a finished mean run (flat over nodes), in block order."""
    plan = partial.plan
    return [derive(partial.block_averages[block].result(), plan.fields, partial.u_ref, partial.dim, plan.convention)
            for block in sorted(partial.block_averages)]


def standard_error(blocks):
    """Standard error of the mean of the block means ``blocks`` (B, ...): over the leading axis."""
    n = blocks.shape[0]
    return np.sqrt(((blocks - blocks.mean(axis=0)) ** 2).sum(axis=0) / (n * (n - 1)))


def lag_one_correlation(blocks):
    """Median over nodes and components (with a spread and finite values) of the lag-1 correlation of the
    block means ``blocks`` (B, ...); NaN if no component spreads."""
    flat = blocks.reshape(blocks.shape[0], -1)
    flat = flat[:, np.all(np.isfinite(flat), axis=0)]
    dev = flat - flat.mean(axis=0)
    denominator = (dev ** 2).sum(axis=0)
    scale = np.abs(flat).max(axis=0)
    spreads = denominator > (1e-12 * scale) ** 2 * flat.shape[0]   # more than rounding
    if not spreads.any():
        return float("nan")
    return float(np.median((dev[:-1] * dev[1:]).sum(axis=0)[spreads] / denominator[spreads]))


def block_errors(partial, n_blocks, stacklevel=3):
    """(standard errors {field: flat array like the field}, lag-1 correlations {field: float}) of a finished
    mean run whose frames were cut into error blocks; warns for correlated block means."""
    per_block = block_fields(partial)
    errors, correlation = {}, {}
    for name in partial.plan.fields:
        blocks = np.stack([fields[name] for fields in per_block])
        errors[name] = standard_error(blocks)
        correlation[name] = lag_one_correlation(blocks)
    limit = CORRELATION_THRESHOLD / np.sqrt(n_blocks)
    correlated = [f"{name} ({r:.2f})" for name, r in correlation.items() if r > limit]
    if correlated:
        warnings.warn(f"consecutive block means are correlated (median lag-1 correlation above "
                      f"{limit:.2f} = {CORRELATION_THRESHOLD:g}/sqrt(n_blocks)) for {', '.join(correlated)}: the "
                      f"blocks of {len(partial.times) // n_blocks} frames are not longer than the flow's "
                      f"correlation time, so the standard errors are too small; use more frames or fewer blocks",
                      CorrelatedBlocksWarning, stacklevel=stacklevel)
    return errors, correlation
