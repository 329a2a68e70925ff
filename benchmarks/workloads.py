"""Benchmark workloads of issue #6, generated with fixed seeds (no files)."""
import numpy as np

import cgbound as cg


def lattice(n=46, spacing=0.99, seed=0):
    """W1: simple-cubic packing of n^3 spheres (d = 1), every neighbour pair in contact.

    Box [0, (n - 1) * spacing + 1]^3 = [0, 45.54]^3 for n = 46, non-periodic; normal forces about 1.
    Returns a Snapshot with 3 n^2 (n - 1) contacts (285,660 for n = 46).
    """
    rng = np.random.default_rng(seed)
    ax = 0.5 + spacing * np.arange(n)
    X, Y, Z = np.meshgrid(ax, ax, ax, indexing="ij")
    pos = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    idx = np.arange(n**3).reshape(n, n, n)
    I, J = [], []
    for axis in range(3):
        a = np.take(idx, range(n - 1), axis=axis).ravel()
        b = np.take(idx, range(1, n), axis=axis).ravel()
        I.append(a)
        J.append(b)
    i, j = np.concatenate(I), np.concatenate(J)
    normal = pos[i] - pos[j]
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    force = normal * rng.uniform(0.9, 1.1, i.size)[:, None]       # repulsive, on i from j
    point = 0.5 * (pos[i] + pos[j])
    L = (n - 1) * spacing + 1.0
    box = cg.Box([0, 0, 0], [L, L, L])
    vel = rng.normal(scale=0.1, size=pos.shape)
    return cg.Snapshot(pos, vel, np.ones(len(pos)), box=box, contacts=cg.Contacts(i, j, force, point))
