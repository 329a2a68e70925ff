"""Lucy's line integrals in closed form (csrc/cg_lucy.c) against 50-digit mpmath quadrature on hard cases,
the slow twin (tests/oracle.py), and the row-by-row grid path against node-by-node evaluation bit for bit."""
import mpmath as mp
import numpy as np
import pytest

import cgbound as cg
from cgbound import _core, _engine
from helpers import assert_fields_close, narrow_build, random_snapshot
from oracle import OracleKernel, oracle_coarse_grain
from stability_log import record
from test_hard_cases import boundary_snapshot, psi_of_boundary_stress, rel_error

mp.mp.dps = 50
RTOL = 1e-12
CONTACT_FIELDS = ("contact_stress", "boundary_stress", "stress", "extended_stress")


def mp_lucy(r2, R, dim):
    """Lucy's kernel at squared distance r2 (mpf), by its textbook form."""
    R = mp.mpf(R)
    if r2 >= R * R:
        return mp.mpf(0)
    x = mp.sqrt(r2) / R
    C = 5 / (mp.pi * R**2) if dim == 2 else 105 / (16 * mp.pi * R**3)
    return C * (1 + 3 * x) * (1 - x) ** 3


def mp_lucy_psi(q, e, R):
    """int_0^1 W(q - s e) ds in 50 digits: tanh-sinh quadrature over the part inside the support, split
    at the closest approach (q, e taken exactly as floats)."""
    q = [mp.mpf(float(x)) for x in q]
    e = [mp.mpf(float(x)) for x in e]
    dim, R_ = len(q), mp.mpf(R)
    L = mp.sqrt(sum(x * x for x in e))
    if L == 0:
        return mp_lucy(sum(x * x for x in q), R, dim)
    u = sum(a * b for a, b in zip(q, e)) / L
    a2 = sum((qa - u * ea / L) ** 2 for qa, ea in zip(q, e))
    if a2 >= R_ * R_:
        return mp.mpf(0)
    b = mp.sqrt(R_ * R_ - a2)
    hi, lo = min(u, b), max(u - L, -b)
    if lo >= hi:
        return mp.mpf(0)
    edges = [lo, mp.mpf(0), hi] if lo < 0 < hi else [lo, hi]
    return mp.quad(lambda t: mp_lucy(a2 + t * t, R, dim), edges) / L


def lucy_psi(nodes, particle, point, R):
    """psi at the nodes from the boundary stress of one wall contact (branch particle -> point)."""
    dim = len(particle)
    box = cg.Box(np.full(dim, -5e6), np.full(dim, 5e6))
    force = np.array([0.3, -0.2, 1.0][:dim])
    snap = boundary_snapshot(particle, point, force, box)
    out = cg.coarse_grain(snap, cg.Points(nodes), cg.Lucy(R), fields=("boundary_stress",))
    return psi_of_boundary_stress(out, force, snap.positions[0] - point)


def check_psi(nodes, particle, point, R, what):
    psi = lucy_psi(nodes, particle, point, R)
    ref = np.array([float(mp_lucy_psi(p - particle, point - particle, R)) for p in nodes])
    err = rel_error(psi, ref)
    record(f"Lucy closed form: {what}", err)
    assert err <= RTOL, what


@pytest.mark.parametrize("ratio", [0.0, 1e-16, 1e-13, 1e-10, 1e-7, 1e-5, 1e-3, 0.3, 3.0])
def test_nearly_zero_length_and_long_branches(ratio):
    R = 0.7
    particle = np.array([0.11, -0.07, 0.05])
    point = particle + ratio * R * np.array([0.6, -0.64, 0.48])
    nodes = particle + np.random.default_rng(2).normal(scale=0.5 * R, size=(12, 3))
    if ratio == 0.0:
        # zero length: the boundary stress vanishes with the branch, so ask the core for psi itself
        target = _engine.core_target(cg.Points(nodes), cg.Box([-9] * 3, [9] * 3))
        psi = _core.scatter_segments(target, _engine.core_kernel(cg.Lucy(R), 1.0), particle[None], np.zeros((1, 3)),
                                     np.ones((1, 1)))[:, 0]
        ref = np.array([float(mp_lucy_psi(p - particle, np.zeros(3), R)) for p in nodes])
        assert rel_error(psi, ref) <= RTOL
        return
    check_psi(nodes, particle, point, R, f"L/R = {ratio:g}")


@pytest.mark.parametrize("where", [-0.9, -0.3, 0.0, 0.25, 0.5, 1.0, 1.2, 1.9])
def test_nodes_on_the_segments_line(where):
    """a = 0 (r^3 = |t|^3 and the asinh term vanishes) and a at round-off level, on and beyond the segment."""
    R = 1.3
    particle = np.array([0.2, 0.1, -0.3])
    e = np.array([0.9, 0.3, -0.2])
    point = particle + e
    on = particle + where * e
    nodes = np.array([on, on + 1e-14 * np.array([0.3, -0.9, 0.1]), on + 1e-9 * np.array([0.0, 0.2, 0.98]),
                      on + 1e-4 * np.array([1.0, 0.0, 0.0])])
    check_psi(nodes, particle, point, R, f"nodes on the line at s = {where}")


@pytest.mark.parametrize("scale", [1e-100, 1e-150, 1e-160, 1e-250])
def test_tiny_segments_with_nodes_as_close(scale):
    """A segment of length scale R with nodes within a few scale R of it (on it, beside it, beyond its ends):
    r0 - r1 and the log's argument share a reciprocal of a product that underflows near 1e-150 R (the closed
    form then drops terms below the result's last digit); the value is W at the node, finite, against 50 digits."""
    R = 0.8
    particle = np.array([0.3, -0.2, 0.1])
    e = scale * R * np.array([0.48, 0.6, -0.64])
    offsets = scale * R * np.array([[0.0, 0.0, 0.0], [0.24, 0.3, -0.32], [2.0, -1.0, 0.5], [-1.5, 0.2, 0.1],
                                    [0.1, 1e-3, 0.0], [0.6, 0.0, 0.8]])
    nodes = particle + offsets
    target = _engine.core_target(cg.Points(nodes), cg.Box([-9] * 3, [9] * 3))
    psi = _core.scatter_segments(target, _engine.core_kernel(cg.Lucy(R), 1.0), particle[None], e[None],
                                 np.ones((1, 1)))[:, 0]
    ref = np.array([float(mp_lucy_psi(p - particle, e, R)) for p in offsets + particle])
    err = rel_error(psi, ref)
    record(f"Lucy closed form: segment and nodes within {scale:g} R", err)
    assert err <= RTOL


@pytest.mark.parametrize("depth", [1e-12, 1e-8, 1e-4, 1e-2])
def test_nodes_at_the_edge_of_the_support(depth):
    """Nodes whose distance to the segment is R (1 - depth): the support clips a tiny piece."""
    R = 1.0
    particle = np.zeros(3)
    e = np.array([1.0, 0.0, 0.0])
    perp = np.array([0.0, 0.6, 0.8])
    nodes = np.array([0.4 * e + (1 - depth) * R * perp,                    # beside the middle
                      -(1 - depth) * R * e,                                 # beyond the start, on the line
                      e + (1 - depth) * R * (0.6 * e + 0.8 * perp),         # beyond the end, off the line
                      0.5 * e])                                             # the scale of the field
    check_psi(nodes, particle, particle + e, R, f"support edge, depth {depth:g}")


@pytest.mark.parametrize("tilt", [0.0, 1e-15, 1e-9, 1e-4])
def test_far_from_the_origin_with_a_small_cutoff(tilt):
    """Positions near 1e6 with R = 1e-3: every node offset is taken as the core takes it (q = node - start)."""
    R = 1e-3
    particle = np.array([1e6 + 0.123, -1e6 + 0.456, 1e6 - 0.789])
    point = particle + np.array([4e-4, tilt * 4e-4, 3e-4])
    rng = np.random.default_rng(3)
    nodes = particle + rng.uniform(-1.5 * R, 1.5 * R, size=(15, 3))
    check_psi(nodes, particle, point, R, f"near 1e6, R = 1e-3, tilt {tilt:g}")


@pytest.mark.parametrize("seed", range(4))
def test_random_segments_in_2d_and_3d(seed):
    rng = np.random.default_rng(seed)
    for dim in (2, 3):
        R = 10 ** rng.uniform(-2, 1)
        particle = rng.normal(size=dim)
        point = particle + rng.normal(size=dim) * R * 10 ** rng.uniform(-3, 0.5)
        nodes = particle + rng.normal(scale=0.8 * R, size=(10, dim))
        check_psi(nodes, particle, point, R, f"random {dim}D, seed {seed}")


def mp_lucy_gradient(q, e, R):
    """grad psi = int_0^1 grad W(q - s e) ds in 50 digits, split where the integrand is not smooth."""
    q = [mp.mpf(float(x)) for x in q]
    e = [mp.mpf(float(x)) for x in e]
    R_ = mp.mpf(R)
    C = 105 / (16 * mp.pi * R_**3)
    L2 = sum(x * x for x in e)
    u = sum(a * b for a, b in zip(q, e)) / L2          # closest approach, in s
    a2 = sum((qa - u * ea) ** 2 for qa, ea in zip(q, e))
    splits = {mp.mpf(0), mp.mpf(1)}
    if 0 < u < 1:
        splits.add(u)
    if a2 < R_ * R_:
        half = mp.sqrt((R_ * R_ - a2) / L2)
        splits |= {s for s in (u - half, u + half) if 0 < s < 1}
    splits = sorted(splits)

    def component(d):
        def f(s):
            v = [q[k] - s * e[k] for k in range(3)]
            r = mp.sqrt(sum(x * x for x in v))
            return -12 * C * (1 - r / R_) ** 2 * v[d] / R_**2 if r < R_ else mp.mpf(0)
        return float(mp.quad(f, splits))
    return [component(d) for d in range(3)]


def core_gradient(nodes, start, e, R):
    target = _engine.core_target(cg.Points(nodes), cg.Box([-9] * 3, [9] * 3))
    return _core.scatter_segments(target, _engine.core_kernel(cg.Lucy(R), 1.0), start[None], e[None], np.ones((1, 1)),
                                  gradient=True).reshape(-1, 3)


def test_gradient_matches_the_twin():
    """grad psi (the residual's segment term) against quadrature of grad W in the slow twin."""
    rng = np.random.default_rng(7)
    R = 1.1
    ref = OracleKernel("lucy", 3, R, R)
    for length in (1.0, 0.5, 2.0, 0.3, 0.0):
        s = rng.normal(size=3)
        e = rng.normal(size=3) * length
        nodes = np.vstack([rng.normal(size=(40, 3)), s + 0.5 * e + rng.normal(scale=0.3, size=(10, 3))])
        assert_fields_close(core_gradient(nodes, s, e, R), ref.line_gradient(nodes - s, e), RTOL, "gradient")


@pytest.mark.parametrize("length", [1e-10, 1e-6, 1e-3])
def test_gradient_of_short_segments_against_mpmath(length):
    """Short segments, where the twin's quadrature itself loses digits (1.6e-11 at 2.5e-6)."""
    rng = np.random.default_rng(8)
    R = 1.1
    s = rng.normal(size=3)
    e = rng.normal(size=3) * length
    nodes = s + rng.normal(scale=0.5, size=(8, 3))
    got = core_gradient(nodes, s, e, R)
    want = np.array([mp_lucy_gradient(p - s, e, R) for p in nodes])
    err = rel_error(got, want)
    record(f"Lucy closed-form gradient, L = {length:g}", err)
    assert err <= RTOL


@pytest.mark.parametrize("average", [(), ("x",), ("x", "y"), ("z",)])
def test_contact_fields_match_the_twin(average):
    snap = random_snapshot(77, dim=3, periodic=(True, False, False), outside=True)
    names = snap.box.axis_names
    grid = cg.Grid(snap.box, tuple(1 if n in average else s for n, s in zip(names, (6, 5, 7))), average=average)
    for kernel in (cg.Lucy(1.3), cg.Heaviside(1.1)):
        out = cg.coarse_grain(snap, grid, kernel, fields=CONTACT_FIELDS)
        ref = oracle_coarse_grain(snap, grid, kernel, CONTACT_FIELDS)
        for name in CONTACT_FIELDS:
            assert_fields_close(out[name].reshape(ref[name].shape), ref[name], RTOL, f"{name} {average} {kernel}")


@pytest.mark.parametrize("periodic", [(False, False, False), (True, True, False), (True, True, True)])
def test_rows_equal_node_by_node_bit_for_bit(periodic):
    """The row paths on grids (cg_visit_lucy for Lucy's segments, cg_visit_ball_points for Lucy's and
    Heaviside's points, values and fluctuations) compute each node's value as the node-by-node path does."""
    for dim, seed in ((3, 5), (2, 6)):
        snap = random_snapshot(seed, dim=dim, periodic=periodic[:dim], outside=True)
        names = snap.box.axis_names
        for average in ((), names[:1]):
            fields = ("density", "momentum", "kinetic_stress", "contact_stress", "boundary_stress", "stress")
            if not all(p for p, n in zip(periodic[:dim], names) if n not in average):
                fields += ("extended_stress",)   # rays: infinite when every resolved axis is periodic
            grid = cg.Grid(snap.box, tuple(1 if n in average else s for n, s in zip(names, (9, 8, 11))),
                           average=average)
            for R in (0.4, 1.5, 4.0):
                for make in (cg.Lucy, cg.Heaviside):
                    fast_kernel, slow_kernel = make(R), make(R)
                    slow_kernel._per_node = True
                    fast = cg.coarse_grain(snap, grid, fast_kernel, fields=fields)
                    slow = cg.coarse_grain(snap, grid, slow_kernel, fields=fields)
                    narrow = narrow_build(lambda: cg.coarse_grain(snap, grid, fast_kernel, fields=fields))
                    for name in fields:
                        what = f"{name} dim {dim} R {R} {make.__name__} averaged {average}"
                        assert np.array_equal(fast[name], slow[name]), what
                        assert np.array_equal(narrow[name], fast[name]), what + " narrow"


@pytest.mark.skipif(not cg.have_openmp(), reason="serial build")
def test_lattice_rows_do_not_depend_on_the_thread_count():
    """A grid long enough for slabs (cg_scatter.c): the same bits for any thread count."""
    import os
    import sys
    sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "benchmarks"))
    from workloads import lattice
    snap = lattice(n=32)
    grid = cg.Grid(snap.box, (32, 32, 32))
    with cg.threads(1):
        one = cg.coarse_grain(snap, grid, cg.Lucy(1.5), fields=("contact_stress",)).contact_stress
    for n in (2, 3):
        with cg.threads(n):
            many = cg.coarse_grain(snap, grid, cg.Lucy(1.5), fields=("contact_stress",)).contact_stress
        assert np.array_equal(one, many), n
