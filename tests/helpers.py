"""Random snapshots for the tests (flowing and fixed particles, bulk, boundary and wall contacts) and a
run on the narrow vector build."""
import numpy as np

import cgbound as cg
from cgbound import _core


def random_snapshot(seed, dim=3, n=14, n_fixed=4, n_bulk=8, n_fixed_contacts=4, n_wall=3,
                    periodic=None, lengths=None, velocities=True, body_force=True, radii=True,
                    outside=False):
    rng = np.random.default_rng(seed)
    if lengths is None:
        lengths = np.array([4.0, 3.5, 5.0][:dim]) if dim == 3 else np.array([4.0, 5.0])
    lengths = np.asarray(lengths, float)
    lower = rng.uniform(-1, 1, dim)
    upper = lower + lengths
    if periodic is None:
        periodic = tuple([True] * (dim - 1) + [False])
    box = cg.Box(lower, upper, periodic=periodic)
    fixed = np.zeros(n, bool)
    fixed[:n_fixed] = True
    rng.shuffle(fixed)
    # flowing particles above a base of fixed ones, as in a chute: rays of the
    # extended stress then point into the base, not along a periodic axis
    frac = rng.uniform(0.1, 0.9, (n, dim))
    frac[fixed, -1] = rng.uniform(0.05, 0.25, fixed.sum())
    frac[~fixed, -1] = rng.uniform(0.45, 0.95, (~fixed).sum())
    pos = lower + frac * lengths
    if outside:
        # some particles given outside the box / unwrapped across periodic boundaries
        for d in range(dim):
            if periodic[d]:
                pos[: n // 3, d] += lengths[d] * rng.integers(-2, 3, n // 3)
    vel = rng.normal(size=(n, dim)) if velocities else None
    masses = rng.uniform(0.5, 2.0, n)
    flow_idx = np.flatnonzero(~fixed)
    fix_idx = np.flatnonzero(fixed)
    pairs = set()
    I, J, F, C = [], [], [], []

    def contact_point(i, j):
        d = pos[j] - pos[i]
        for a in range(dim):
            if periodic[a]:
                d[a] -= lengths[a] * np.round(d[a] / lengths[a])
        return pos[i] + rng.uniform(0.3, 0.7) * d + 0.05 * rng.normal(size=dim)

    while len(I) < n_bulk:
        i, j = rng.choice(flow_idx, 2, replace=False)
        key = (min(i, j), max(i, j))
        if key in pairs:
            continue
        pairs.add(key)
        I.append(i); J.append(j); F.append(rng.normal(size=dim)); C.append(contact_point(i, j))
    count = 0
    while count < n_fixed_contacts:
        i, j = rng.choice(flow_idx), rng.choice(fix_idx)
        key = (min(i, j), max(i, j))
        if key in pairs:
            continue
        pairs.add(key)
        if rng.random() < 0.5:  # either orientation
            I.append(i); J.append(j); F.append(rng.normal(size=dim)); C.append(contact_point(i, j))
        else:
            I.append(j); J.append(i); F.append(rng.normal(size=dim)); C.append(contact_point(j, i))
        count += 1
    for _ in range(n_wall):
        i = rng.choice(flow_idx)
        off = rng.normal(size=dim)
        off[-1] = -abs(off[-1]) - 0.5  # walls below: a real component along the last (non-periodic) axis
        I.append(i); J.append(-1); F.append(rng.normal(size=dim)); C.append(pos[i] + 0.4 * off / np.linalg.norm(off))
    # one contact between two fixed particles: must be ignored
    if len(fix_idx) >= 2:
        I.append(fix_idx[0]); J.append(fix_idx[1]); F.append(rng.normal(size=dim)); C.append(pos[fix_idx[0]])
    contacts = cg.Contacts(np.array(I), np.array(J), np.array(F).reshape(-1, dim), np.array(C).reshape(-1, dim))
    g = np.zeros(dim)
    g[-1] = -1.0
    return cg.Snapshot(pos, vel, masses, box=box, contacts=contacts, fixed=fixed,
                       body_force=g if body_force else None,
                       radii=rng.uniform(0.2, 0.5, n) if radii else None, time=float(seed))


#: the local radius spread and skewness come from raw moments, which cancel where the local sizes hardly spread
#: (a node seeing one particle): there rounding is amplified without bound, so whole-field comparisons at a
#: fixed tolerance leave them out; tests/test_structure.py compares them where they are conditioned
ILL_CONDITIONED_FIELDS = ("radius_spread", "radius_skewness")


def assert_fields_close(actual, expected, rtol, what=""):
    """Compare arrays relative to the field's scale (max |expected|); NaNs must coincide."""
    actual = np.asarray(actual)
    expected = np.asarray(expected)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    nan_a, nan_e = np.isnan(actual), np.isnan(expected)
    assert np.array_equal(nan_a, nan_e), f"{what}: NaN pattern differs"
    a, e = actual[~nan_a], expected[~nan_e]
    scale = np.max(np.abs(e)) if e.size else 0.0
    err = np.max(np.abs(a - e)) if e.size else 0.0
    assert err <= rtol * scale or err == 0.0, f"{what}: max error {err:.3e} > {rtol:g} x scale {scale:.3e}"
    return err / scale if scale else 0.0


class ForbiddenCore:
    """Stands in for the C core: any scatter means work started that should not have."""

    def __init__(self, real, reason="before the bad input was rejected"):
        self._real = real
        self._reason = reason

    def __getattr__(self, name):
        if name.startswith("scatter"):
            def forbidden(*args, **kwargs):
                raise AssertionError(f"_core.{name} ran {self._reason}")
            return forbidden
        return getattr(self._real, name)


def narrow_build(compute):
    """compute() with the AVX2/baseline build of the vector paths (the default restored after)."""
    previous = _core.set_wide_vectors(False)
    try:
        return compute()
    finally:
        _core.set_wide_vectors(previous)
