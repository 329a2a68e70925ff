"""coarse_grain_tiled with the fields of issue 17 that sum over contact points or half-lines and spinning
particles: the rotational fields (both couple stress forms) and the structure fields equal the one-process
result (cgbound/tiled.py; the contact halo grows by the longest particle-to-contact-point lever)."""
import numpy as np
import pytest

import cgbound
import cgbound as cg
from cgbound.rotation import ROTATION_FIELDS
from helpers import ForbiddenCore, assert_fields_close, random_snapshot
from test_rotation import spinning

STRUCTURE = ("number_density", "fabric", "coordination_number", "size_moment_2", "mean_radius")
FIELDS = ROTATION_FIELDS + STRUCTURE + ("density", "stress")
RTOL = 1e-12

# (dim, periodic, grid shape, averaged axes, tiles)
TILINGS = {
    "periodic": (3, (True, True, False), (9, 8, 10), (), (3, 2, 4)),
    "non-periodic": (3, (False, False, False), (9, 8, 10), (), (3, 2, 4)),
    "one-node-tiles": (3, (True, True, False), (4, 3, 5), (), (4, 3, 5)),
    "averaged-x": (3, (True, True, False), (1, 8, 10), ("x",), (1, 3, 2)),
    "all-periodic": (3, (True, True, True), (6, 6, 6), (), (2, 3, 2)),
    "2d": (2, (True, False), (12, 10), (), (3, 2)),
}
KERNELS = {"gaussian": cg.Gaussian(0.5), "lucy": cg.Lucy(1.2)}


def big_spinning(dim, periodic, seed=5, inertia=False):
    lengths = [8.0, 7.0, 9.0] if dim == 3 else [8.0, 9.0]
    snap = random_snapshot(seed, dim=dim, n=300, n_bulk=250, n_fixed=40, n_fixed_contacts=40, n_wall=20,
                           periodic=periodic, lengths=lengths, outside=True)
    return spinning(snap, seed, inertia=inertia)


def assert_same(whole, tiled, fields, what):
    for name in fields:
        assert np.asarray(tiled[name]).shape == np.asarray(whole[name]).shape, name
        assert_fields_close(np.asarray(tiled[name]), np.asarray(whole[name]), RTOL, f"{what} {name}")
        assert np.any(np.asarray(whole[name]) != 0), f"{what} {name}: an all-zero field checks nothing"


@pytest.mark.parametrize("form", ["contact_point", "branch_line"])
@pytest.mark.parametrize("tiling", TILINGS)
@pytest.mark.parametrize("kname", sorted(KERNELS))
def test_tiled_rotational_and_structure_fields_equal_one_process(kname, tiling, form):
    dim, periodic, shape, average, tiles = TILINGS[tiling]
    kernel = KERNELS[kname]
    snap = big_spinning(dim, periodic, inertia=tiling == "periodic")
    grid = cg.Grid(snap.box, shape, average=average)
    whole = cg.coarse_grain(snap, grid, kernel, fields=FIELDS, couple_stress_form=form)
    tiled = cg.coarse_grain_tiled(snap, grid, kernel, fields=FIELDS, tiles=tiles, backend="serial",
                                  couple_stress_form=form)
    assert_same(whole, tiled, FIELDS, f"{tiling} {form}")


def short_contacts(seed=8, n=400, distance=2.5):
    """Spinning particles in a non-periodic box with contacts between near neighbours only (branches < 1.1),
    every fourth with its contact point moved ``distance`` off the branch: a lever much longer than any branch,
    so only a halo that counts the levers brings those contacts to the tiles that they reach."""
    rng = np.random.default_rng(seed)
    box = cg.Box([0.0, 0.0, 0.0], [8.0, 7.0, 9.0])
    pos = rng.uniform(0, 1, (n, 3)) * box.lengths
    gap = np.linalg.norm(pos[:, None] - pos[None], axis=2)
    i, j = np.nonzero(np.triu(gap < 1.1, 1))
    point = 0.5 * (pos[i] + pos[j])
    off = rng.normal(size=point.shape)
    far = np.arange(i.size) % 4 == 0
    point[far] += distance * off[far] / np.linalg.norm(off[far], axis=1)[:, None]
    walls = np.arange(0, n, 10)                           # boundary contacts a short way below some particles
    contacts = cg.Contacts(np.concatenate([i, walls]), np.concatenate([j, np.full(walls.size, -1)]),
                           rng.normal(size=(i.size + walls.size, 3)),
                           np.concatenate([point, pos[walls] - [0.0, 0.0, 0.4]]))
    return cg.Snapshot(pos, rng.normal(size=(n, 3)), rng.uniform(0.5, 2, n), box=box, contacts=contacts,
                       radii=rng.uniform(0.2, 0.5, n), angular_velocities=rng.normal(size=(n, 3)))


@pytest.mark.parametrize("form", ["contact_point", "branch_line"])
def test_contact_points_far_from_the_branch_reach_their_tiles(form):
    snap = short_contacts()
    kernel = cg.Lucy(1.0)
    bulk, boundary = snap.split_contacts()
    longest = max(np.linalg.norm(p["branch"], axis=1).max() for p in (bulk, boundary))
    lever = np.linalg.norm(snap.positions[bulk["i"]] - bulk["point"], axis=1)
    # the check has teeth: many contact points lie beyond the branch-only halo (radius + longest branch)
    assert longest < 1.1 and (lever > kernel.radius + longest + 0.3).sum() >= 50
    grid = cg.Grid(snap.box, (9, 8, 10))
    fields = ("fabric", "coordination_number", "couple_stress", "stress_torque_density")
    whole = cg.coarse_grain(snap, grid, kernel, fields=fields, couple_stress_form=form)
    tiled = cg.coarse_grain_tiled(snap, grid, kernel, fields=fields, tiles=(3, 2, 4), backend="serial",
                                  couple_stress_form=form)
    assert_same(whole, tiled, fields, form)


def test_tiled_spin_fields_alone_need_no_contacts():
    """Spin fields only: no contact is split or sent; the given moments of inertia are used, not 2/5 m r^2."""
    snap = big_spinning(3, (True, True, False), inertia=True)
    grid = cg.Grid(snap.box, (9, 8, 10))
    fields = ("spin_density", "spin_flux", "kinetic_spin_flux")
    whole = cg.coarse_grain(snap, grid, cg.Gaussian(0.5), fields=fields)
    tiled = cg.coarse_grain_tiled(snap, grid, cg.Gaussian(0.5), fields=fields, tiles=(3, 2, 2), backend="serial")
    assert_same(whole, tiled, fields, "spin only")
    spheres = cg.Snapshot(snap.positions, snap.velocities, snap.masses, box=snap.box, fixed=snap.fixed,
                          radii=snap.radii, angular_velocities=snap.angular_velocities)
    other = cg.coarse_grain(spheres, grid, cg.Gaussian(0.5), fields=("spin_density",))
    assert np.abs(other.spin_density - tiled.spin_density).max() > 1e-3 * np.abs(tiled.spin_density).max()


@pytest.fixture
def no_work(monkeypatch):
    monkeypatch.setattr(cgbound._engine, "_core", ForbiddenCore(cgbound._engine._core))


def test_tiles_refuse_what_coarse_grain_refuses_before_work(no_work):
    snap = big_spinning(3, (True, True, False))
    grid = cg.Grid(snap.box, (1, 8, 10), average=("x",))
    with pytest.raises(ValueError, match="couple_stress_form: 'branch_line' .*needs exact line integrals"):
        cg.coarse_grain_tiled(snap, grid, cg.Gaussian(0.5, line_quadrature="mercurycg"), fields=("couple_stress",),
                              tiles=(1, 2, 2), backend="serial", couple_stress_form="branch_line")
    with pytest.raises(ValueError, match="couple_stress_form: expected 'contact_point' or 'branch_line'"):
        cg.coarse_grain_tiled(snap, grid, cg.Gaussian(0.5), fields=("couple_stress",), tiles=(1, 2, 2),
                              backend="serial", couple_stress_form="branch")
    still = cg.Snapshot(snap.positions, snap.velocities, snap.masses, box=snap.box, fixed=snap.fixed,
                        radii=snap.radii)
    with pytest.raises(ValueError, match="snapshot.angular_velocities: expected angular velocities"):
        cg.coarse_grain_tiled(still, grid, cg.Lucy(1.2), fields=("density", "spin_density"), tiles=(1, 2, 2),
                              backend="serial")
    no_radii = cg.Snapshot(snap.positions, snap.velocities, snap.masses, box=snap.box, fixed=snap.fixed,
                           angular_velocities=snap.angular_velocities)
    with pytest.raises(ValueError, match="moments_of_inertia: expected moments of inertia, or radii"):
        cg.coarse_grain_tiled(no_radii, grid, cg.Lucy(1.2), fields=("spin_density",), tiles=(1, 2, 2),
                              backend="serial")


def test_tiled_rotational_fields_on_a_dask_cluster():
    """The tiles' spin data and second particles travel to Dask workers (pickled _TileData) intact."""
    pytest.importorskip("distributed")
    snap = big_spinning(2, (True, False))
    grid = cg.Grid(snap.box, (12, 10))
    fields = ROTATION_FIELDS + ("fabric",)
    whole = cg.coarse_grain(snap, grid, cg.Lucy(1.0), fields=fields, couple_stress_form="branch_line")
    tiled = cg.coarse_grain_tiled(snap, grid, cg.Lucy(1.0), fields=fields, tiles=(3, 2), n_workers=1,
                                  couple_stress_form="branch_line")
    assert_same(whole, tiled, fields, "dask")
