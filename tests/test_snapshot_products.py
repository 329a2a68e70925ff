"""Snapshot's product checks look at flowing particles only: a fixed particle's mass, velocity, body
force and radius neither raise nor enter largest_product (with some particles fixed and with none)."""
import numpy as np
import pytest

import cgbound as cg


def particles(seed, n=50):
    rng = np.random.default_rng(seed)
    pos = rng.random((n, 3)) * 10.0
    vel = rng.normal(size=(n, 3))
    masses = rng.random(n) + 0.5
    radii = rng.random(n) * 0.2 + 0.1
    force = rng.normal(size=(n, 3))
    return pos, vel, masses, radii, force


@pytest.mark.parametrize("seed", range(4))
def test_fixed_particles_do_not_count(seed):
    pos, vel, masses, radii, force = particles(seed)
    fixed = np.zeros(len(masses), bool)
    fixed[[3, 17]] = True
    vel[3], masses[17], radii[3], force[17] = 1e200, 1e300, 1e150, 1e290   # products beyond any bound
    box = cg.Box([0, 0, 0], [10, 10, 10])
    whole = cg.Snapshot(pos, vel, masses, box=box, radii=radii, body_force=force, fixed=fixed)
    flow = ~fixed
    alone = cg.Snapshot(pos[flow], vel[flow], masses[flow], box=box, radii=radii[flow], body_force=force[flow])
    assert whole.largest_product == alone.largest_product
    with pytest.raises(ValueError, match="velocities: expected velocities whose momentum flux"):
        cg.Snapshot(pos, vel, masses, box=box, radii=radii, body_force=force)


@pytest.mark.parametrize("seed", range(4))
def test_no_fixed_particle_gives_the_values_of_each_row(seed):
    pos, vel, masses, radii, force = particles(seed)
    snap = cg.Snapshot(pos, vel, masses, box=cg.Box([0, 0, 0], [10, 10, 10]), radii=radii, body_force=force)
    speed = np.abs(vel).max(axis=1)
    want = max(masses.max(), (masses * np.abs(force).max(axis=1)).max(), (masses * speed * speed).max(),
               (masses * speed).max(), (4.2 * radii ** 3).max())
    assert snap.largest_product == want
