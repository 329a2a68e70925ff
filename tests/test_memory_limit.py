"""A request whose output cannot fit in memory is a MemoryError stating the size, raised before allocating."""
import re
import tracemalloc

import numpy as np
import pytest

import cgbound
from helpers import ForbiddenCore
import cgbound as cg
import cgbound._memory as memory
import cgbound.pipeline as pipeline
from cgbound.fields import FIELDS

HUGE = (100000, 100000, 100)  # 1e12 nodes: terabytes for any field


@pytest.fixture
def no_work(monkeypatch):
    monkeypatch.setattr(cgbound._engine, "_core", ForbiddenCore(cgbound._engine._core, "although memory was about to run out"))


def small_snapshot(n=10, seed=0):
    rng = np.random.default_rng(seed)
    box = cg.Box([0, 0, 0], [1, 1, 1])
    pos = rng.uniform(0, 1, (n, 3))
    contacts = cg.Contacts([0, 1], [1, 2], rng.normal(size=(2, 3)), 0.5 * (pos[[0, 1]] + pos[[1, 2]]))
    return cg.Snapshot(pos, rng.normal(size=(n, 3)), np.ones(n), box=box, contacts=contacts)


def gb_in(message):
    found = re.search(r"about ([0-9.]+) GB", message)
    assert found, message
    return float(found.group(1))


def traced_peak(call):
    tracemalloc.start()
    try:
        call()
    finally:
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
    return peak


def test_huge_grid_is_a_memory_error_before_allocating(no_work):
    snap = small_snapshot()
    grid = cg.Grid(snap.box, HUGE)
    errors = []

    def call():
        with pytest.raises(MemoryError) as info:
            cg.coarse_grain(snap, grid, cg.Lucy(0.1), fields=("stress",))
        errors.append(info.value)

    peak = traced_peak(call)
    assert peak < 20e6, f"{peak / 1e6:.1f} MB allocated before the MemoryError"
    message = str(errors[0])
    assert message.startswith("grid: expected a request that fits in memory")
    assert re.search(r"1000000000000 nodes", message)
    # stress in 3D: at least the 5 primaries rho, p_w, sk, sb, sw (1 + 3 + 3 x 9 doubles) and the output (9)
    assert gb_in(message) >= 8 * 1e12 * (31 + 9) / 1e9
    assert re.search(r"of physical memory", message)


def test_huge_grid_in_coarsegrain_run(no_work):
    snaps = [small_snapshot(seed=s) for s in range(3)]
    grid = cg.Grid(snaps[0].box, HUGE)
    run = cg.CoarseGrain(snaps, grid, cg.Gaussian(0.05), fields=("density",), time_average="none")
    peak = traced_peak(lambda: pytest.raises(MemoryError, run.run).match(r"grid: .* GB"))
    assert peak < 20e6


def test_memory_error_uses_physical_memory(no_work, monkeypatch):
    """A modest request on a (pretend) tiny machine: the comparison is with physical memory."""
    snap = small_snapshot()
    grid = cg.Grid(snap.box, (10, 10, 10))
    monkeypatch.setattr(memory, "physical_memory", lambda: 10_000)
    with pytest.raises(MemoryError, match=r"grid: .*about 0\.0 GB \(1000 nodes x \d+ doubles .*0\.0 GB of physical"):
        cg.coarse_grain(snap, grid, cg.Lucy(0.3), fields=("density",))
    with pytest.raises(MemoryError, match=r"points: expected a request that fits in memory"):
        cg.momentum_balance_residual(snap, grid.coordinates.reshape(-1, 3), cg.Lucy(0.3))
    with pytest.raises(MemoryError, match=r"grid: "):
        cg.CoarseGrain([snap], grid, cg.Lucy(0.3), fields=("density",)).run()


def test_threshold_is_the_estimate(monkeypatch):
    need = memory.check_fits("grid", 1000, 7)
    assert need == 8 * 1000 * 7
    monkeypatch.setattr(memory, "physical_memory", lambda: need)
    memory.check_fits("grid", 1000, 7)
    monkeypatch.setattr(memory, "physical_memory", lambda: need - 1)
    with pytest.raises(MemoryError):
        memory.check_fits("grid", 1000, 7)
    monkeypatch.setattr(memory, "physical_memory", lambda: None)  # platform does not say: no check
    memory.check_fits("grid", 10**15, 100)


def test_physical_memory_is_from_sysconf():
    import os
    assert memory.physical_memory() == os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


class FakeCore:
    def __init__(self, openmp, threads=8):
        self.openmp = openmp
        self.threads = threads

    def have_openmp(self):
        return self.openmp

    def default_threads(self):
        return self.threads if self.openmp else 1


def test_thread_count(monkeypatch):
    import cgbound._engine as engine

    monkeypatch.setattr(engine, "_core", FakeCore(True, 8))
    assert memory.core_threads() == 8                 # the OpenMP default
    assert memory.core_threads(n_objects=3) == 3    # the core never runs more threads than objects
    assert memory.core_threads(n_objects=0) == 1
    with cg.threads(4):
        assert memory.core_threads() == 4
    previous = cg.set_num_threads(3)
    try:
        assert memory.core_threads() == 3
    finally:
        cg.set_num_threads(previous)
    monkeypatch.setattr(engine, "_core", FakeCore(False))
    assert memory.core_threads() == 1
    assert cg.have_openmp() in (True, False)


def test_per_thread_buffers_are_counted():
    needed = cgbound.fields.needed_primaries(("stress",))
    one = pipeline.per_node_doubles(needed, ("stress",), 3, threads=1)
    eight = pipeline.per_node_doubles(needed, ("stress",), 3, threads=8)
    assert eight - one == 7 * 9                        # 7 extra copies of the widest scatter (a 3x3 tensor)
    # rho 1 + p_w 3 + sk 9 + sb 9 + sw 9 primaries, node velocities 3, output 9, one temporary 9, and
    # the one scatter of rho and p_w together (4) before it is split into its primaries
    assert one == 31 + 3 + 9 + 9 + 4
    dens = pipeline.per_node_doubles({"rho"}, ("density",), 2, threads=2)
    assert dens == 1 + 1 + 1 + 1 + 1                     # primary, one thread copy, output, temporary, scatter
    frames = pipeline.per_node_doubles({"rho"}, ("density",), 2, threads=1, frames=10, time_average="none")
    assert frames == 1 + 1 + 1 + 1 + 2 * 10


def test_modest_request_still_runs():
    snap = small_snapshot()
    out = cg.coarse_grain(snap, cg.Grid(snap.box, (4, 4, 4)), cg.Lucy(0.5), fields=("stress", "density"))
    assert np.all(np.isfinite(out.stress))
