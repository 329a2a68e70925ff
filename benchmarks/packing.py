"""A dense random granular packing on a rough base, with soft-sphere contacts (fixed seed, no files).

Used by the accuracy-versus-time study. The box is periodic on all three axes; a layer of fixed
particles (a jittered square lattice, the rough base) sits at the bottom, so through the periodic
z axis the flowing packing is squeezed between the base and its image: every flowing particle near
the base has boundary contacts. Flowing particles start at random positions at a packing fraction
above jamming and are relaxed by moving overlapping pairs apart, which leaves a jammed packing with
small overlaps. Contact forces are linear springs on those overlaps, so forces are consistent with
the positions (the momentum balance of the coarse-grained fields can be checked pointwise).
"""
import math

import numpy as np

import cgbound as cg


def _pairs_within(pos, reach, lengths):
    """Pairs (i < j) closer than reach[i] + reach[j] under the minimum image, brute force in chunks."""
    n = len(pos)
    I, J = [], []
    chunk = max(1, 2_000_000 // max(n, 1))
    for start in range(0, n, chunk):
        idx = np.arange(start, min(n, start + chunk))
        d = pos[idx, None, :] - pos[None, :, :]
        d -= lengths * np.round(d / lengths)
        r2 = np.einsum("abk,abk->ab", d, d)
        lim = reach[idx, None] + reach[None, :]
        a, b = np.nonzero((r2 < lim * lim) & (idx[:, None] < np.arange(n)[None, :]))
        I.append(idx[a])
        J.append(b)
    return np.concatenate(I), np.concatenate(J)


def _separations(pos, i, j, lengths):
    d = pos[i] - pos[j]
    d -= lengths * np.round(d / lengths)
    r = np.linalg.norm(d, axis=1)
    return d, r


def dense_packing(size=10.0, diameter=1.0, polydispersity=0.1, packing_fraction=0.66, steps=400, seed=0,
                  velocity_scale=0.1):
    """Snapshot of a jammed polydisperse packing on a fixed rough base in a periodic cube of side ``size``.

    Diameters are uniform in diameter * [1 - polydispersity, 1 + polydispersity]; masses are
    proportional to d^3 (density 6/pi, so a particle of diameter 1 has mass 1). Contact forces on i
    from j are k * overlap * n_ij with k set so that the mean force magnitude is 1; contact points lie
    on the centre line. Velocities are Gaussian with the given scale (so kinetic fields are not empty).
    """
    rng = np.random.default_rng(seed)
    L = float(size)
    lengths = np.array([L, L, L])
    # rough base: fixed particles of the nominal diameter on a square lattice, jittered in z
    nb = max(1, int(round(L / diameter)))
    ax = (np.arange(nb) + 0.5) * (L / nb)
    bx, by = np.meshgrid(ax, ax, indexing="ij")
    base = np.stack([bx.ravel(), by.ravel(), 0.5 * diameter + rng.uniform(-0.1, 0.1, nb * nb) * diameter], axis=1)
    d_base = np.full(len(base), diameter)
    # flowing particles fill the rest of the cube above the base at the requested packing fraction
    lo, hi = 1.0 - polydispersity, 1.0 + polydispersity
    mean_d3 = diameter ** 3 * (hi ** 4 - lo ** 4) / (4 * (hi - lo)) if polydispersity > 0 else diameter ** 3
    free_volume = L * L * (L - diameter)
    n = int(round(packing_fraction * free_volume / (math.pi / 6 * mean_d3)))
    d_flow = diameter * rng.uniform(lo, hi, n)
    flow = np.column_stack([rng.uniform(0, L, n), rng.uniform(0, L, n), rng.uniform(diameter, L, n)])
    pos = np.concatenate([base, flow])
    diam = np.concatenate([d_base, d_flow])
    fixed = np.zeros(len(pos), bool)
    fixed[:len(base)] = True
    radius = 0.5 * diam
    # relax: push overlapping pairs apart (fixed particles do not move); the pair list is rebuilt
    # every few steps with a skin, and a step never moves a particle more than 0.1 d
    skin = 0.3 * diameter
    for step in range(steps):
        if step % 10 == 0:
            i, j = _pairs_within(pos, radius + 0.5 * skin, lengths)
        dvec, r = _separations(pos, i, j, lengths)
        overlap = radius[i] + radius[j] - r
        touch = overlap > 0
        if not touch.any():
            break
        ii, jj = i[touch], j[touch]
        push = (0.5 * overlap[touch] / np.maximum(r[touch], 1e-12))[:, None] * dvec[touch]
        move = np.zeros_like(pos)
        np.add.at(move, ii, push)
        np.add.at(move, jj, -push)
        move[fixed] = 0.0
        step_len = np.linalg.norm(move, axis=1)
        move *= np.minimum(1.0, 0.1 * diameter / np.maximum(step_len, 1e-300))[:, None] * 0.5
        pos += move
        pos %= lengths
    # contacts: every overlapping pair that is not fixed-fixed, force on i from j along n_ij
    i, j = _pairs_within(pos, radius, lengths)
    dvec, r = _separations(pos, i, j, lengths)
    overlap = radius[i] + radius[j] - r
    keep = (overlap > 0) & ~(fixed[i] & fixed[j])
    i, j, dvec, r, overlap = i[keep], j[keep], dvec[keep], r[keep], overlap[keep]
    normal = dvec / r[:, None]
    stiffness = 1.0 / overlap.mean()
    force = (stiffness * overlap)[:, None] * normal
    point = pos[i] - (radius[i] - 0.5 * overlap)[:, None] * normal   # on the centre line, inside the overlap
    point %= lengths
    masses = diam ** 3
    vel = rng.normal(scale=velocity_scale, size=pos.shape)
    vel[fixed] = 0.0
    box = cg.Box([0.0, 0.0, 0.0], lengths, periodic=True)
    return cg.Snapshot(pos, vel, masses, box=box, contacts=cg.Contacts(i, j, force, point), fixed=fixed,
                       radii=radius)


if __name__ == "__main__":
    import time
    t = time.perf_counter()
    snap = dense_packing()
    c = snap.contacts
    boundary = snap.fixed[c.i] | snap.fixed[c.j]
    flow = snap.flowing
    phi = (math.pi / 6 * (2 * snap.radii[flow]) ** 3).sum() / np.prod(snap.box.lengths)
    print(snap, f"{boundary.sum()} boundary contacts; phi {phi:.3f}; "
          f"contacts per flowing particle {2 * len(c) / flow.sum():.2f}; {time.perf_counter() - t:.2f} s")
