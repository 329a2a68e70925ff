"""The paper's scenes (Weinhart et al. 2012, section 3) and the binary collision that checks the contact model.

Units: flowing particle diameter d = 1, mass m = 1, gravity g = 1.
"""
import numpy as np

from ...box import Box
from .lammps import Trace
from .scene import PAPER_CONTACT_MODEL, PAPER_TIMESTEP, Scene


def _periodic_delta(d, lengths, periodic):
    for a, (length, p) in enumerate(zip(lengths, periodic)):
        if p:
            d[..., a] -= length * np.round(d[..., a] / length)
    return d


def _random_sequential(rng, count, lower, upper, min_distance, periodic_lengths, existing=None,
                       existing_distance=None, horizontal=False, max_attempts=2_000_000):
    """Place ``count`` points uniformly at random, each at least ``min_distance`` from the others
    (and ``existing_distance`` from ``existing``); distances horizontal (x, y) only if asked."""
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    axes = slice(0, 2) if horizontal else slice(None)
    periodic = [L is not None for L in periodic_lengths]
    lengths = [L or 1.0 for L in periodic_lengths]
    placed = np.empty((0, lower.size))
    for _ in range(max_attempts):
        if count is not None and len(placed) >= count:
            break
        p = lower + rng.random(lower.size) * (upper - lower)
        ok = True
        for others, dist in ((placed, min_distance), (existing, existing_distance)):
            if others is None or len(others) == 0:
                continue
            d = _periodic_delta(others[:, axes] - p[axes], lengths[axes], periodic[axes])
            if np.min(np.einsum("ij,ij->i", d, d)) < dist * dist:
                ok = False
                break
        if ok:
            placed = np.vstack([placed, p])
    if count is not None and len(placed) < count:
        raise RuntimeError(f"could place only {len(placed)} of {count} particles")
    return placed


def binary_collision(contacts=PAPER_CONTACT_MODEL, speed=1.0, timestep=PAPER_TIMESTEP, mass=1.0, diameter=1.0):
    """Two equal particles approaching head-on along x, no gravity (checks t_c and restitution)."""
    gap = 0.5 * speed * 20 * timestep  # touch after ~10 steps
    x = np.array([[-0.5 * diameter - gap, 0.0, 0.0], [0.5 * diameter + gap, 0.0, 0.0]])
    v = np.array([[0.5 * speed, 0.0, 0.0], [-0.5 * speed, 0.0, 0.0]])
    box = Box([-5.0, -5.0, -5.0], [5.0, 5.0, 5.0], periodic=False)
    return Scene("binary_collision", box, x, np.full(2, 0.5 * diameter), np.full(2, mass), contacts,
                 velocities=v, gravity=None, rotation=False, timestep=timestep)


def measure_collision(scene, executable=None):
    """Run a :func:`binary_collision` scene; returns (contact duration, restitution coefficient).

    The contact starts and ends where the gap between the surfaces changes sign (linear
    interpolation between steps); restitution is the ratio of the relative normal speeds
    after and before.
    """
    from .runner import run_scene
    rel_speed = abs(scene.velocities[1, 0] - scene.velocities[0, 0])
    duration = 3.0 * scene.contacts.collision_time(0.5 * scene.masses[0]) + 40 * scene.timestep
    steps = int(np.ceil(duration / scene.timestep))
    run = run_scene(scene, [Trace(steps * scene.timestep, every=1)], executable=executable)
    t, x, v = run.trace["time"], run.trace["positions"], run.trace["velocities"]
    gap = np.linalg.norm(x[:, 1] - x[:, 0], axis=1) - scene.radii.sum()
    touching = np.flatnonzero(gap < 0)
    if touching.size == 0 or touching[-1] == len(gap) - 1:
        raise RuntimeError("measure_collision: the particles did not collide and separate within the trace")
    first, last = touching[0], touching[-1]

    def crossing(k):  # zero of the gap between steps k and k + 1
        return t[k] + (t[k + 1] - t[k]) * gap[k] / (gap[k] - gap[k + 1])
    contact_time = crossing(last) - crossing(first - 1)
    after = abs(v[-1, 1, 0] - v[-1, 0, 0])
    return contact_time, after / rel_speed


def boundary_2d(contacts=PAPER_CONTACT_MODEL, timestep=PAPER_TIMESTEP, seed=3):
    """Fig. 1: five fixed and five flowing discs (2D, gravity -z), to be relaxed until static.

    The fixed discs (diameter 1) lie on z = 0 with gaps between them, the flowing discs
    (diameters 0.9-1.1) start just above them and fall into place.
    """
    rng = np.random.default_rng(seed)
    fixed_x = np.array([0.0, 1.25, 2.5, 3.75, 5.0])
    fixed_pos = np.stack([fixed_x, np.zeros(5)], axis=1)
    flow_r = 0.5 * rng.uniform(0.9, 1.1, 5)
    flow_pos = np.array([[0.62, 1.0], [1.88, 1.0], [3.12, 1.0], [4.38, 1.0], [2.5, 2.0]])
    flow_pos[:, 1] += flow_r - 0.5 + 0.05
    flow_pos[4, 1] += 0.1
    positions = np.concatenate([fixed_pos, flow_pos])
    radii = np.concatenate([np.full(5, 0.5), flow_r])
    masses = (2 * radii / 1.0) ** 3  # m = 1 for d = 1 (same density in 3D units)
    fixed = np.arange(10) < 5
    box = Box([-1.0, -1.0], [6.0, 4.0], periodic=False)
    return Scene("boundary_2d", box, positions, radii, masses, contacts, fixed=fixed,
                 gravity=np.array([0.0, -1.0]), rotation=True, timestep=timestep)


def chute(n_flowing=1000, length=20.0, width=10.0, angle=26.0, base_diameter=2.0, contacts=PAPER_CONTACT_MODEL,
          timestep=PAPER_TIMESTEP, seed=2012, flowing_diameters=None):
    """Figs. 2-3: a 3D chute periodic in x and y, inclined at ``angle`` degrees (gravity tilted).

    The rough base: fixed particles of diameter ``base_diameter`` with centres placed at random
    in the slab -d_base/2 <= z <= 0 with horizontal spacing at least 0.6 d_base, dense enough
    that a flowing particle cannot pass (checked). The flowing particles (d = 1, m = 1) start
    at random non-overlapping positions above the base, at rest.

    ``flowing_diameters=(low, high)`` draws the flowing diameters uniformly from [low, high] instead
    (masses d^3, the density of the d = 1, m = 1 particles; positions at least ``high`` apart).
    """
    if flowing_diameters is None:
        low = high = 1.0
    else:
        low, high = (float(v) for v in flowing_diameters)
        if not (np.isfinite(low) and np.isfinite(high) and 0 < low <= high):
            raise ValueError(f"flowing_diameters: expected (low, high) with 0 < low <= high, got {flowing_diameters!r}")
    rng = np.random.default_rng(seed)
    lengths = (length, width, None)
    rb = 0.5 * base_diameter
    base = _random_sequential(rng, None, [0, 0, -rb], [length, width, 0.0], 0.6 * base_diameter, lengths,
                              horizontal=True, max_attempts=20000)
    # no flowing particle may slip between base particles: every point of the plane z = -rb/2
    # must lie inside some base particle grown by the flowing radius
    gx, gy = np.meshgrid(np.linspace(0, length, 401), np.linspace(0, width, 201), indexing="ij")
    probe = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, -0.5 * rb)], axis=1)
    nearest = np.full(len(probe), np.inf)
    for b in base:
        d = _periodic_delta(probe - b, (length, width, 1.0), (True, True, False))
        nearest = np.minimum(nearest, np.einsum("ij,ij->i", d, d))
    if np.sqrt(nearest.max()) >= rb + 0.5 * low:
        raise RuntimeError("chute: the base has a hole a flowing particle can fall through")
    top = 0.0 + rb
    height = n_flowing * (np.pi / 6) * high ** 3 / (0.3 * length * width)  # start at volume fraction ~0.3
    flow = _random_sequential(rng, n_flowing, [0, 0, top + 0.6], [length, width, top + 0.6 + height], high, lengths,
                              existing=base, existing_distance=rb + 0.5 * high)
    positions = np.concatenate([base, flow])
    flowing_radii = np.full(n_flowing, 0.5) if flowing_diameters is None else 0.5 * rng.uniform(low, high, n_flowing)
    radii = np.concatenate([np.full(len(base), rb), flowing_radii])
    masses = (2 * radii) ** 3
    fixed = np.arange(len(positions)) < len(base)
    theta = np.radians(angle)
    gravity = np.array([np.sin(theta), 0.0, -np.cos(theta)])
    box = Box([0.0, 0.0, -base_diameter], [length, width, top + 0.6 + height + 1.0], periodic=(True, True, False))
    return Scene(f"chute_{angle:g}deg_N{n_flowing}", box, positions, radii, masses, contacts, fixed=fixed,
                 gravity=gravity, rotation=True, timestep=timestep)


__all__ = ["binary_collision", "measure_collision", "boundary_2d", "chute"]
