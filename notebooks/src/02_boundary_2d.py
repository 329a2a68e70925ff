# %% [markdown]
# # Fig. 1: the interaction force density and the stress near a boundary
#
# The paper's two-dimensional scene: five fixed and five flowing discs under gravity (-z), with the
# paper's contact model (`cgbound.paper.scenes.PAPER_CONTACT_MODEL`), relaxed with LAMMPS until static.
# With LAMMPS installed the scene is simulated here (about a second); otherwise the relaxed frame
# shipped with cgbound (made by the same scene, `scripts/make_boundary_2d_dataset.py`) is used.

# %%
import numpy as np
import matplotlib.pyplot as plt
import cgbound as cg
from cgbound import plot
from cgbound.paper import scenes
from cgbound.paper.blobs import blob_centroids

scene = scenes.boundary_2d()
print(scene)
if scenes.find_lammps():
    run = scenes.run_scene(scene, [scenes.Settle(tolerance=1e-20), scenes.Frames(1, 0.5)])
    snap = run.snapshots[0]
    print(f"LAMMPS relaxed it in {run.wall_time:.1f} s: kinetic energy {run.thermo['kinetic_energy'][-1]:.1e} at t = {snap.time:g}")
else:
    from cgbound.paper.datasets import boundary_2d
    snap = boundary_2d()
    print("LAMMPS not installed: using the shipped relaxed frame")
snap.units = "mercury"            # the paper's units: diameter d = mass m = gravity g = 1 (labels say so)
snap

# %% [markdown]
# Coarse-grain at the paper's very small width w = d/8 so the spatial averaging is visible.

# %%
w = 1 / 8
grid = cg.Grid(cg.Box([-1, -1], [6, 3]), (560, 320))   # spacing w/10
out = cg.coarse_grain(snap, grid, cg.Gaussian(w), fields=("interaction_force_density", "stress"))
t_norm = plot.norm(out, "interaction_force_density")      # |t|
sigma_norm = plot.norm(out, "stress")                     # |sigma| = max over unit x of |sigma x|
nodes = np.stack(np.meshgrid(*grid.axis_coordinates, indexing="ij"), axis=-1).reshape(-1, 2)

# %% [markdown]
# **Check 1: the IFD centres on the flow-boundary contact points.** Each node within 2w of a contact
# point is given to its nearest contact point; the |t|-weighted centroid of each blob must lie within
# w/10 of its contact point.

# %%
c = snap.contacts
boundary = snap.fixed[c.i] != snap.fixed[c.j]
points = c.point[boundary]
centroids = blob_centroids(t_norm, nodes, points, radius=2 * w)
offsets = np.linalg.norm(centroids - points, axis=1)
print(f"{len(points)} flow-boundary contacts; centroid offsets / w: max {offsets.max() / w:.4f}")
assert offsets.max() < w / 10

# %% [markdown]
# **Check 2: the stress lies along the contact lines** (from each flowing particle's centre to its
# contact points). A line source smeared by a 2D Gaussian puts a fraction erf(k/√2) of its weight
# within k·w of the line (68.3 %, 95.4 %, 99.73 % for k = 1, 2, 3); the stress norm must do at least as well at 3w.

# %%
def distance_to_segment(p, a, b):
    ab = b - a
    s = np.clip((p - a) @ ab / (ab @ ab), 0, 1)
    return np.linalg.norm(p - (a + s[:, None] * ab), axis=1)

lines = [(snap.positions[a], p) for i, j, p in zip(c.i, c.j, c.point) for a in (i, j) if not snap.fixed[a]]
distance = np.min([distance_to_segment(nodes, a, b) for a, b in lines], axis=0)
weight = sigma_norm.reshape(-1)
from math import erf, sqrt
for k in (1, 2, 3):
    print(f"within {k} w of a contact line: {weight[distance <= k * w].sum() / weight.sum():.4f}   (line source: {erf(k / sqrt(2)):.4f})")
assert weight[distance <= 3 * w].sum() / weight.sum() >= erf(3 / sqrt(2))

# %%
fig, axes = plt.subplots(1, 2, figsize=(11, 3.6), constrained_layout=True)
for ax, name, title in zip(axes, ("interaction_force_density", "stress"), ("|t|", "|σ| = max |σx|")):
    plot.field_map(out, name, ax=ax)
    plot.particles(ax, snap)
    ax.set_title(f"{title}, w = d/8")
axes[0].plot(*points.T, "r+", ms=6)
plt.show()
