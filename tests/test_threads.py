"""Thread count control (set_num_threads, get_num_threads, threads()) and results independent of it."""
import numpy as np
import pytest

import cgbound as cg
from helpers import assert_fields_close


def packing(n=3000, seed=3):
    """Enough particles and contacts on a fine enough grid that the core really splits the work."""
    rng = np.random.default_rng(seed)
    box = cg.Box([0, 0, 0], [10, 10, 10], periodic=(True, False, False))
    pos = rng.uniform(0, 10, (n, 3))
    i = rng.integers(0, n, 4 * n)
    j = (i + 1 + rng.integers(0, n - 1, i.size)) % n
    near = np.linalg.norm(pos[i] - pos[j], axis=1) < 2.0
    pairs = np.unique(np.sort(np.stack([i[near], j[near]], axis=1), axis=1), axis=0)
    i, j = pairs[:, 0], pairs[:, 1]
    force = rng.normal(size=(i.size, 3))
    contacts = cg.Contacts(i, j, force, 0.5 * (pos[i] + pos[j]))
    return cg.Snapshot(pos, rng.normal(size=(n, 3)), rng.uniform(0.5, 2, n), box=box, contacts=contacts)


FIELDS = ("density", "momentum", "momentum_flux", "kinetic_stress", "contact_stress", "stress")


@pytest.mark.skipif(not cg.have_openmp(), reason="serial build")
@pytest.mark.parametrize("kernel", [cg.Gaussian(0.5, cutoff=1.5), cg.Gaussian(0.5, cutoff=1.5, line_quadrature=3),
                                    cg.Lucy(1.2)], ids=repr)
def test_results_do_not_depend_on_the_thread_count(kernel):
    snap = packing()
    grid = cg.Grid(snap.box, (20, 20, 20))
    points = cg.Points(np.random.default_rng(1).uniform(0, 10, (500, 3)))
    for where in (grid, points):
        with cg.threads(1):
            one = cg.coarse_grain(snap, where, kernel, fields=FIELDS)
        for n in (2, 3):
            with cg.threads(n):
                many = cg.coarse_grain(snap, where, kernel, fields=FIELDS)
            for name in FIELDS:
                assert_fields_close(many[name], one[name], 1e-12, f"{name} with {n} threads")


def test_set_get_and_context_manager():
    previous = cg.set_num_threads(None)
    try:
        default = cg.get_num_threads()
        assert default >= 1
        if cg.have_openmp():
            cg.set_num_threads(3)
            assert cg.get_num_threads() == 3
            with cg.threads(1):
                assert cg.get_num_threads() == 1
                with cg.threads(2):
                    assert cg.get_num_threads() == 2
                assert cg.get_num_threads() == 1
            assert cg.get_num_threads() == 3
            assert cg.set_num_threads(None) == 3
            assert cg.get_num_threads() == default
        else:
            with cg.threads(4):
                assert cg.get_num_threads() == 1
    finally:
        cg.set_num_threads(previous)


@pytest.mark.parametrize("bad,error", [(0, ValueError), (-1, ValueError), (1.5, TypeError), ("2", TypeError),
                                       (True, TypeError), (4097, ValueError), (10 ** 30, ValueError)])
def test_bad_thread_counts_are_refused(bad, error):
    with pytest.raises(error, match="n: expected"):
        cg.set_num_threads(bad)
    with pytest.raises(error, match="n: expected"):
        with cg.threads(bad):
            pass


def test_core_refuses_negative_thread_count():
    target = (2, (0, 1), None, np.zeros((1, 2)), [False, False], [1.0, 1.0])
    with pytest.raises(ValueError, match="n_threads"):
        cg._core.scatter_points(target, (0, 1.0, 3.0, 0, 1.0), np.zeros((1, 2)), np.ones((1, 1)), n_threads=-1)


def lattice_packing(shape=(30, 4, 4), spacing=0.8, seed=5):
    """A jittered lattice, long along x, in a non-periodic box with short contacts (the core then cuts the
    objects into slabs along x); the bottom layer also touches a wall (boundary contacts)."""
    rng = np.random.default_rng(seed)
    axes = [0.5 + spacing * np.arange(m) for m in shape]
    pos = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    pos += rng.uniform(-0.05, 0.05, pos.shape)
    idx = np.arange(len(pos)).reshape(shape)
    i = np.concatenate([np.take(idx, range(shape[a] - 1), axis=a).ravel() for a in range(3)])
    j = np.concatenate([np.take(idx, range(1, shape[a]), axis=a).ravel() for a in range(3)])
    walls = idx[:, :, 0].ravel()
    contacts = cg.Contacts(np.concatenate([i, walls]), np.concatenate([j, -np.ones(walls.size, int)]),
                           rng.normal(size=(i.size + walls.size, 3)),
                           np.concatenate([0.5 * (pos[i] + pos[j]), pos[walls] - [0, 0, 0.5]]))
    box = cg.Box([0, 0, 0], [spacing * (m - 1) + 1.0 for m in shape])
    return cg.Snapshot(pos, rng.normal(size=pos.shape), rng.uniform(0.5, 2, len(pos)), box=box, contacts=contacts)


def same_bits_for_any_thread_count(snap, grid, kernel, fields):
    """Assert that 2 and 3 threads give one thread's fields bit for bit; returns one thread's result."""
    with cg.threads(1):
        one = cg.coarse_grain(snap, grid, kernel, fields=fields)
    for n in (2, 3):
        with cg.threads(n):
            many = cg.coarse_grain(snap, grid, kernel, fields=fields)
        for name in fields:
            np.testing.assert_array_equal(many[name], one[name], err_msg=f"{name} with {n} threads")
    return one


@pytest.mark.parametrize("line_quadrature", ["exact", 1, 3])
def test_slabs_sum_in_the_same_order_for_any_thread_count(line_quadrature):
    """On a grid of many nodes along x (non-periodic) the core cuts the objects into slabs that write to
    disjoint nodes: results are then bit-for-bit the same for every thread count, and right."""
    from oracle import oracle_coarse_grain
    snap = lattice_packing()
    grid = cg.Grid(snap.box, (100, 4, 5))
    kernel = cg.Gaussian(0.3, cutoff=0.9, line_quadrature=line_quadrature)
    fields = ("density", "momentum", "contact_stress", "boundary_stress", "interaction_force_density")
    one = same_bits_for_any_thread_count(snap, grid, kernel, fields)
    ref = oracle_coarse_grain(snap, grid, kernel, fields)
    for name in fields:
        assert_fields_close(one[name].reshape(ref[name].shape), ref[name], 1e-10, name)


@pytest.mark.skipif(not cg.have_openmp(), reason="serial build")
def test_per_thread_copies_start_from_zero_when_their_memory_is_reused():
    """Where slabs do not apply (here: a periodic first axis), threads other than the first sum into copies of the
    output whose memory the core keeps from one call to the next. Each call must start them from zero: the same
    call repeated, after calls on larger and smaller grids, gives the same sums to the bit, close to one thread's."""
    snap = packing()
    kernel = cg.Gaussian(0.5, cutoff=1.5)
    fields = ("density", "momentum_flux", "contact_stress")
    grids = [cg.Grid(snap.box, shape) for shape in ((12, 10, 8), (24, 20, 16), (6, 5, 4))]
    with cg.threads(1):
        one = [cg.coarse_grain(snap, grid, kernel, fields=fields) for grid in grids]
    for n in (2, 3):
        with cg.threads(n):
            first = [cg.coarse_grain(snap, grid, kernel, fields=fields) for grid in grids]
            again = [cg.coarse_grain(snap, grid, kernel, fields=fields) for grid in reversed(grids)][::-1]
        for k, grid in enumerate(grids):
            for name in fields:
                np.testing.assert_array_equal(again[k][name], first[k][name],
                                              err_msg=f"{name} on {grid.shape} with {n} threads, repeated")
                assert_fields_close(first[k][name], one[k][name], 1e-12, f"{name} on {grid.shape} with {n} threads")


@pytest.mark.skipif(not cg.have_openmp(), reason="serial build")
def test_concurrent_calls_do_not_share_per_thread_copies():
    """Calls from several Python threads at once (the GIL is released in the core) each get their own per-thread
    copies: every result equals the same call's made alone, to the bit."""
    from concurrent.futures import ThreadPoolExecutor

    snap = packing()
    kernel = cg.Gaussian(0.5, cutoff=2.0)   # the core's work long enough for the calls to overlap
    grid = cg.Grid(snap.box, (40, 40, 40))
    with cg.threads(2):
        alone = cg.coarse_grain(snap, grid, kernel, fields=("contact_stress",))["contact_stress"]

        def run(_):
            with cg.threads(2):
                return cg.coarse_grain(snap, grid, kernel, fields=("contact_stress",))["contact_stress"]

        with ThreadPoolExecutor(4) as pool:
            results = list(pool.map(run, range(8)))
    for k, result in enumerate(results):
        np.testing.assert_array_equal(result, alone, err_msg=f"call {k}")


@pytest.mark.skipif(not cg.have_openmp(), reason="serial build")
def test_spatial_order_on_several_threads_is_the_serial_one():
    """With enough objects (32,768 per thread) the core counts and places them in spatial order on several
    threads; the order must be the one-thread order, or the slabs' sums (bit for bit for any thread count) would
    change: random particles and contacts in a long non-periodic box, 1, 2 and 3 threads."""
    rng = np.random.default_rng(11)
    m = 40_000                                          # triples of particles, each with its 3 contacts
    box = cg.Box([0, 0, 0], [60, 6, 6])
    centres = rng.uniform(0.5, np.asarray(box.lengths) - 0.5, (m, 3))
    pos = np.concatenate([centres + rng.uniform(-0.3, 0.3, (m, 3)) for _ in range(3)])
    n = len(pos)
    a, b, c = np.arange(m), np.arange(m) + m, np.arange(m) + 2 * m
    i, j = np.concatenate([a, a, b]), np.concatenate([b, c, c])
    contacts = cg.Contacts(i, j, rng.normal(size=(i.size, 3)), 0.5 * (pos[i] + pos[j]))
    snap = cg.Snapshot(pos, rng.normal(size=(n, 3)), rng.uniform(0.5, 2, n), box=box, contacts=contacts)
    grid = cg.Grid(box, (120, 12, 12))
    kernel = cg.Gaussian(0.25, cutoff=0.75)
    fields = ("density", "momentum_flux", "contact_stress")
    same_bits_for_any_thread_count(snap, grid, kernel, fields)
