"""cg_quartic_roots (csrc/cg_quartic.c), the breakpoints of the ring segment rules: bit for bit against its NumPy
twin (tests/oracle.py), over dtypes, layouts and thread counts; against the eigenvalues of the companion matrices
(the rule it replaced) and against quartics built from known roots."""
import numpy as np
import pytest

from cgbound import _engine
from cgbound.cylindrical_ring import segment_quartic

from oracle import oracle_quartic_roots


def quartics(n=300, seed=0):
    """Random quartics, ones with known simple, double and complex roots, and the rings' segment quartics."""
    rng = np.random.default_rng(seed)
    random = rng.normal(size=(n, 5)) * rng.uniform(0.1, 10.0, (n, 1))
    known = rng.uniform(-2, 2, (n, 4))
    known[: n // 4, 1] = known[: n // 4, 0]                           # a double root
    simple = np.array([np.poly(r) for r in known]) * rng.uniform(0.5, 3.0, (n, 1))
    x0, a_perp = rng.uniform(-3, 3, (n, 2)), rng.normal(size=(n, 2))
    rings = segment_quartic(1.5, rng.uniform(-1, 1, n), x0, a_perp, rng.normal(size=n), 1.2)
    return np.concatenate([random, simple, rings]), known


def test_quartic_roots_against_twin_bit_for_bit():
    coef, _ = quartics()
    got = _engine.quartic_roots(coef)
    want = oracle_quartic_roots(coef)
    assert got.shape == (len(coef), 4) and got.dtype == complex
    assert np.array_equal(got, want)


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_quartic_roots_do_not_depend_on_the_thread_count_or_layout(threads):
    coef, _ = quartics(n=400, seed=2)
    want = _engine.quartic_roots(coef, n_threads=1)
    assert np.array_equal(_engine.quartic_roots(coef, n_threads=threads), want)
    assert np.array_equal(_engine.quartic_roots(np.asfortranarray(coef), n_threads=threads), want)
    wide = np.repeat(coef, 2, axis=1)[:, ::2]                          # strided columns
    assert np.array_equal(_engine.quartic_roots(wide, n_threads=threads), want)
    assert np.array_equal(_engine.quartic_roots(coef.tolist(), n_threads=threads), want)
    c32 = coef.astype(np.float32)
    assert np.array_equal(_engine.quartic_roots(c32), _engine.quartic_roots(c32.astype(float)))


def test_quartic_roots_agree_with_the_companion_eigenvalues():
    coef, known = quartics(n=1000, seed=1)
    got = _engine.quartic_roots(coef)
    comp = np.zeros((len(coef), 4, 4))
    comp[:, 0, :] = -coef[:, 1:] / coef[:, :1]
    comp[:, 1, 0] = comp[:, 2, 1] = comp[:, 3, 2] = 1.0
    eig = np.linalg.eigvals(comp)
    n = len(known)
    simple = np.r_[0:n, 2 * n:3 * n]                  # random and segment quartics (no built-in double roots)
    scale = np.maximum(1.0, np.abs(eig).max(axis=1))
    # each eigenvalue has an Aberth root next to it and vice versa
    for a, b in ((got, eig), (eig, got)):
        gap = np.abs(a[:, :, None] - b[:, None, :]).min(axis=2).max(axis=1) / scale
        assert np.quantile(gap[simple], 0.99) < 1e-13
        assert gap[simple].max() < 1e-6                # near-multiple roots: conditioning, as the eigenvalues'
    # quartics from known roots: simple ones to 1e-12, double ones to the square root of the rounding
    built = got[n:2 * n]
    err = np.abs(np.sort(built.real, axis=1) - np.sort(known, axis=1))
    assert err[n // 4:].max() < 1e-9
    assert err[: n // 4].max() < 1e-6
    assert np.abs(built.imag[n // 4:]).max() < 1e-9


def test_quartic_roots_refuse_bad_coefficients():
    coef, _ = quartics(n=4)
    bad = coef.copy()
    bad[2, 0] = 0.0
    with pytest.raises(ValueError, match="coef: expected a nonzero leading coefficient in every row, got 0 in row 2"):
        _engine.quartic_roots(bad)
    bad = coef.copy()
    bad[1, 3] = np.nan
    with pytest.raises(ValueError, match="coef: expected finite values"):
        _engine.quartic_roots(bad)
    with pytest.raises(ValueError, match="coef: expected length 5 along axis 1"):
        _engine.quartic_roots(coef[:, :4])
    assert _engine.quartic_roots(np.zeros((0, 5))).shape == (0, 4)
