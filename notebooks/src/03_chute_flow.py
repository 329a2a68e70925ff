# %% [markdown]
# # Figs. 2-3: steady chute flow over a rough base
#
# The paper's 3D scene (`cgbound.paper.scenes.chute`): 1000 flowing particles (d = 1, m = 1) on a disordered
# base of fixed particles of diameter 2, periodic in x ∈ [0, 20] and y ∈ [0, 10], inclined at 26°,
# with the paper's contact model, simulated with LAMMPS from random positions at rest by
# `scripts/make_chute_dataset.py`. The shipped frames cover the paper's window t ∈ [2000, 2100].

# %%
import json
import numpy as np
import matplotlib.pyplot as plt
import cgbound as cg
from cgbound.paper import scenes
from cgbound.paper.datasets import chute_steady, chute_kinetic_energy
from cgbound.paper.profiles import DepthProfiles

frames = chute_steady()
info = json.loads(frames.provenance)
print(scenes.chute())
print(f"{len(frames)} frames, t = {frames[0].time:g} ... {frames[len(frames) - 1].time:g}, "
      f"every {info['frame_interval']:g}; LAMMPS took {info['lammps_wall_time_s']:.0f} s")

# %% [markdown]
# **The window is steady.** The kinetic energy of the flow, printed by LAMMPS every time unit from the
# start, rises while the flow accelerates and then only fluctuates. Block means of 100 time units
# before and inside the window must agree with each other within their scatter.

# %%
time, kinetic = chute_kinetic_energy()
window = (time >= frames[0].time) & (time <= frames[len(frames) - 1].time)
blocks = [kinetic[(time >= t0) & (time < t0 + 100)].mean() for t0 in range(1000, 2100, 100)]
scatter = np.std(blocks[:-1])
print("block means of the kinetic energy, t = 1000 ... 2100:", np.round(blocks, 1))
print(f"window mean {blocks[-1]:.1f}; earlier blocks {np.mean(blocks[:-1]):.1f} ± {scatter:.1f}")
assert abs(blocks[-1] - np.mean(blocks[:-1])) < 3 * scatter

fig, ax = plt.subplots(figsize=(7, 3), constrained_layout=True)
ax.plot(time, kinetic, lw=0.6)
ax.axvspan(frames[0].time, frames[len(frames) - 1].time, color="C1", alpha=0.3, label="averaging window")
ax.plot([], [], lw=0.6, color="C0", label="kinetic energy (LAMMPS thermo)")
ax.set_xlabel("t [√(d/g)]"); ax.set_ylabel("kinetic energy of the flow [m g d]"); ax.legend()
plt.show()

# %% [markdown]
# **Fig. 2**: a steady-state frame, shaded by speed.

# %%
snap = frames[len(frames) - 1]
flow = snap.flowing
speed = np.linalg.norm(snap.velocities[flow], axis=1)
fig = plt.figure(figsize=(8, 4.5))
ax = fig.add_subplot(projection="3d")
ax.scatter(*snap.positions[snap.fixed].T, s=30, c="0.3", label="fixed base particles")
p = ax.scatter(*snap.positions[flow].T, s=8, c=speed, cmap="gray", label="flowing particles")
ax.set_xlabel("x [d]"); ax.set_ylabel("y [d]"); ax.set_zlabel("z [d]")
ax.set_box_aspect((20, 10, 8))
# the colorbar sits clear of the z tick labels (pad), with its own label
fig.colorbar(p, ax=ax, label="speed |v| [√(g d)]", shrink=0.6, pad=0.12)
ax.legend(loc="upper left", fontsize=8)
plt.show()

# %% [markdown]
# **Fig. 3**: depth profiles averaged over x, y (analytically) and t with w = d/4: σzz without the
# boundary correction (dashed), σ′zz from eq. (27) (solid) and the weight of the flow above z
# (red dotted); bed and surface where σ′zz is within 2 % of its maximum and falls to 2 % of it.
# Eq. (27) is checked against the extended stress of eq. (24) computed directly (ray integrals).

# %%
from cgbound.paper.datasets import chute_dense_profiles
profiles = DepthProfiles(width=0.25, rays=True, blocks=5).run(frames)
print("shipped frames:", profiles.summary())
ray_gap = np.max(np.abs(profiles.ray_extended_stress_zz - profiles.extended_stress_zz)) / profiles.total_weight
print(f"eq. (27) vs eq. (24): max difference {ray_gap:.1e} of the weight")
assert ray_gap < 1e-3
expected_weight = 1000 * np.cos(np.radians(26)) / (20 * 10)      # N m g cos(theta) / area
assert abs(profiles.total_weight / expected_weight - 1) < 1e-3
assert profiles.bed < profiles.surface

# %% [markdown]
# **Sampling.** The contact forces of this collisional flow come in short stiff impacts: the upward
# force of the base on the flow scatters by about 20 % of the weight from one instantaneous frame
# to the next, so 101 frames one time unit apart leave a sampling error of a few per cent (estimated
# above from block averages). The paper takes a frame every t_c/2, which resolves every impact and
# turns the frame average into the time integral of the momentum balance. The profiles shipped in
# `chute_dense_profiles()` were made that way by `scripts/check_chute_dense_sampling.py` (4001 frames
# every t_c/2 over 10 time units, continuing the shipped run); eq. (27), the weight, bed and surface
# are recomputed here from their averaged σzz, t_z and ρ g_z. **The lithostatic balance holds within 1 %.**

# %%
dense = chute_dense_profiles()
print("paper's sampling:", dense.summary())
assert dense.lithostatic_error < 0.01
assert abs(dense.total_weight / expected_weight - 1) < 1e-3
# both estimates agree on where the bed and the surface are (within a tenth of a particle diameter)
assert abs(dense.bed - profiles.bed) < 0.1 and abs(dense.surface - profiles.surface) < 0.1

fig, axes = plt.subplots(1, 2, figsize=(9.5, 4.6), sharey=True, constrained_layout=True)
for ax, prof, title in zip(axes, (profiles, dense), ("101 shipped frames", "4001 frames every $t_c/2$")):
    prof.plot(ax)
    ax.set_title(f"{title}: lithostatic error {100 * prof.lithostatic_error:.2f} %", fontsize=9)
plt.show()

# %% [markdown]
# Without the boundary correction σzz falls off towards the base where the flow meets the rough
# boundary: near the bed it misses part of the weight, which the interaction force density carries.

# %%
near_bed = np.argmin(np.abs(dense.z - dense.bed))
print(f"at the bed: sigma_zz = {dense.stress_zz[near_bed]:.3f}, sigma'_zz = {dense.extended_stress_zz[near_bed]:.3f}, "
      f"weight above = {dense.weight[near_bed]:.3f}")
assert dense.stress_zz[near_bed] < 0.9 * dense.extended_stress_zz[near_bed]
