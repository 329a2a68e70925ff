# %% [markdown]
# # A static silo in cylindrical coordinates: the Janssen effect
#
# The scene `cgbound.paper.scenes.silo`: 2000 frictional spheres (d = 0.9 … 1.1, m ∝ d³, m = 1 for d = 1)
# in a vertical cylinder of radius R = 4 (D = 8) with a flat bottom, gravity −z, frictional Hookean
# contacts (sliding friction μ = 0.5 between particles and against both walls). LAMMPS let the
# particles fall and come to rest, lowered the bottom slowly by 0.2 d so that the column slid down
# along the wall (which mobilises the wall friction), and let it come to rest again
# (`scripts/make_silo_data.py`; the dumps are shipped in `tests/data/lammps/silo`). The side wall is a
# `fix wall/gran/region` with a cylinder region: its `contacts` output gives every particle's contact
# force and contact point on the wall, so the wall is a boundary with an interaction force density (IFD).
#
# All fields are averaged over the angle θ and given in the local basis (e_r, e_θ, e_z) on a
# `cg.CylindricalGrid`.

# %%
import os
import numpy as np
import matplotlib.pyplot as plt
import cgbound as cg
from cgbound.paper.scenes import SILO_CONTACT_MODEL, SILO_TIMESTEP
from cgbound.paper.scenes.lammps import PAIR_VALUES
from cgbound.readers.lammps import LammpsReader


def shipped(name):
    """A file of the shipped silo run (tests/data/lammps/silo in the source tree)."""
    here = os.path.abspath(".")
    while True:
        path = os.path.join(here, "tests", "data", "lammps", "silo", name)
        if os.path.exists(path) or os.path.dirname(here) == here:
            return path
        here = os.path.dirname(here)


frames = LammpsReader(shipped("frames.atoms.dump.gz"), shipped("frames.pairs.dump.gz"), pair_values=PAIR_VALUES,
                      walls=["wall0", "wall1"], body_force=(0.0, 0.0, -1.0), dt=SILO_TIMESTEP, units="mercury")
snap = frames[len(frames) - 1]
R, D, g = 4.0, 8.0, 1.0
mu_wall = SILO_CONTACT_MODEL.friction
mismatch = frames.force_mismatch(len(frames) - 1)
print(snap, f"\n{len(frames)} frames; per-particle force balance of the last one: {mismatch:.1e}")

# %% [markdown]
# **The column and its walls.** The wall contacts are told apart by where they touch: on the cylinder
# (r = R) or on the bottom (z = z_bottom). The column is at rest: the forces of both walls carry the
# weight up to the kinetic residue (the sum of the particle forces LAMMPS dumped, total mass × mean
# acceleration).

# %%
c = snap.contacts
wall = c.j < 0
side = wall & np.isclose(np.hypot(c.point[:, 0], c.point[:, 1]), R, rtol=0, atol=1e-9)
base = wall & ~side
z_bottom = c.point[base, 2].max()
weight = snap.masses.sum() * g
residue = frames.dumped_forces(len(frames) - 1).sum(axis=0)
print(f"weight {weight:.2f}; carried by the side wall {c.force[side, 2].sum():.2f} "
      f"({c.force[side, 2].sum() / weight:.0%}), by the bottom {c.force[base, 2].sum():.2f}; "
      f"kinetic residue {residue[2]:.1e}")
assert abs(c.force[side, 2].sum() + c.force[base, 2].sum() - weight - residue[2]) < 1e-9 * weight

top = np.sort(snap.positions[:, 2] + snap.radii)[-20:].mean()       # the free surface: mean top of the 20 highest
height = top - z_bottom
rho_bulk = snap.masses.sum() / (np.pi * R ** 2 * height)
print(f"column height H = {height:.2f} = {height / D:.1f} D; bulk density {rho_bulk:.3f} "
      f"(volume fraction {rho_bulk / (6 / np.pi):.3f})")

# %% [markdown]
# **Coarse graining on a cylindrical grid**, θ-averaged, with a Gaussian of width w = 0.5: r from the axis
# to R + 3w (the IFD of the wall contacts, centred on r = R, spreads over a few w on both sides) and z
# along the column.

# %%
w = 0.5
grid = cg.CylindricalGrid(snap.box, axis_point=(0.0, 0.0, 0.0), axis="z", r=(0.0, R + 3 * w, 23),
                          theta=None, z=(z_bottom - 3 * w, top + 3 * w, 90))
out = cg.coarse_grain(snap, grid, cg.Gaussian(w), convention="compression",
                      fields=("density", "stress", "pressure", "interaction_force_density"))
r, z = grid.r, grid.z
depth = top - z
rho = out.density[:, 0, :]                      # (n_r, n_z)
sigma = out.stress[:, 0, :]                     # (n_r, n_z, 3, 3) in (e_r, e_θ, e_z), compression positive
t = out.interaction_force_density[:, 0, :]      # (n_r, n_z, 3)
# mass check: ∫ρ 2πr dr dz over the grid is the total mass (the kernel lies inside the grid)
mass = np.trapezoid(np.trapezoid(rho * 2 * np.pi * r[:, None], r, axis=0), z)
print(f"∫ρ dV = {mass:.2f}, total mass {snap.masses.sum():.2f}")

# %% [markdown]
# **Radial profiles**, averaged over three depth bands (one frame is noisy: force chains): density,
# pressure, σ_rr and σ_zz, and the shear σ_rz, which vanishes on the axis by symmetry and carries the
# wall friction. Within about 2w of the wall the kernel reaches past r = R, where there are no particles,
# so every field falls off there (the wall's own force is in the IFD, below).

# %%
bands = [(0.25 * D, 0.75 * D), (1.0 * D, 2.0 * D), (2.5 * D, 4.5 * D)]
fig, axes = plt.subplots(1, 4, figsize=(13, 3.4), constrained_layout=True)
for lo, hi in bands:
    band = (depth >= lo) & (depth < hi)
    label = f"depth {lo / D:g}–{hi / D:g} D"
    axes[0].plot(r, rho[:, band].mean(axis=1), label=label)
    axes[1].plot(r, out.pressure[:, 0, band].mean(axis=1), label=label)
    axes[2].plot(r, sigma[:, band, 0, 0].mean(axis=1), label=label)
    axes[2].plot(r, sigma[:, band, 2, 2].mean(axis=1), ls="--", color=axes[2].lines[-1].get_color())
    axes[3].plot(r, sigma[:, band, 0, 2].mean(axis=1), label=label)
for ax, name in zip(axes, ("density ρ", "pressure p", "σ_rr (solid), σ_zz (dashed)", "σ_rz")):
    ax.axvline(R, color="0.5", lw=0.8)
    ax.set(xlabel="r", title=name)
axes[0].legend(fontsize=8)
fig

# %% [markdown]
# **The vertical stress saturates with depth (Janssen).** A slice of the column between the free surface
# and depth z carries its weight partly on the wall (friction) and passes the rest down:
# σ̄_zz(z) πR² = (weight above) − (wall friction above). The θ-averaged σ_zz averaged over the cross
# section must follow this discrete balance, and both follow Janssen's law
# σ_zz(z) = (ρ g D / 4 μ_w K)(1 − exp(−4 μ_w K z / D)) with the bulk density ρ and the wall friction μ_w = 0.5
# of the scene, and K (the ratio σ_rr / σ_zz at the wall) fitted.

# %%
inside = r <= R
sigma_zz_mean = 2 / R ** 2 * np.trapezoid(sigma[inside, :, 2, 2] * r[inside, None], r[inside], axis=0)

# the discrete balance, from the particles and the wall contacts alone
x = snap.positions
above_mass = np.array([snap.masses[x[:, 2] > zk].sum() for zk in z])
above_friction = np.array([c.force[side & (c.point[:, 2] > zk), 2].sum() for zk in z])
sigma_zz_discrete = (above_mass * g - above_friction) / (np.pi * R ** 2)

def janssen(depth, K):
    return rho_bulk * g * D / (4 * mu_wall * K) * (1 - np.exp(-4 * mu_wall * K * np.clip(depth, 0, None) / D))


fit_range = (depth > 2 * w) & (z > z_bottom + 3 * w)       # away from the free surface and the bottom
# one parameter: least squares over a fine scan of K, refined once around the best value
scan = np.linspace(0.01, 3.0, 300)
for _ in range(2):
    misfit = [np.sum((janssen(depth[fit_range], k) - sigma_zz_mean[fit_range]) ** 2) for k in scan]
    best = scan[np.argmin(misfit)]
    scan = np.linspace(best - 0.01, best + 0.01, 201)
K = best
print(f"fitted K = {K:.3f}; Janssen's saturation ρ g D / (4 μ_w K) = {rho_bulk * g * D / (4 * mu_wall * K):.1f} "
      f"vs hydrostatic ρ g H = {rho_bulk * g * height:.1f}")

in_column = z >= z_bottom
fig, ax = plt.subplots(figsize=(5.5, 4.2), constrained_layout=True)
ax.plot(sigma_zz_mean[in_column], depth[in_column], label="σ̄_zz (coarse-grained)")
ax.plot(sigma_zz_discrete[in_column], depth[in_column], ls=":", label="(weight − wall friction) above / πR²")
ax.plot(janssen(depth, K)[in_column], depth[in_column], ls="--", label=f"Janssen, K = {K:.2f}")
ax.plot(rho_bulk * g * np.clip(depth, 0, None)[in_column], depth[in_column], color="0.6", lw=0.8,
        label="hydrostatic ρ g z")
ax.set(xlabel="vertical stress", ylabel="depth below the free surface", xlim=(0, 1.2 * sigma_zz_mean.max()))
ax.invert_yaxis()
ax.legend(fontsize=8)
fig

# %% [markdown]
# **The wall stresses from the boundary IFD.** The IFD t of the wall contacts is a force per volume smeared
# around r = R; integrated across the wall it is the wall traction: per unit wall area,
# τ_w(z) = (1/R) ∫ t_z r dr (shear, upwards on the particles) and σ_w(z) = −(1/R) ∫ t_r r dr (normal).
# The same numbers straight from the wall contacts, binned in z, are shown as steps. Janssen's balance
# dσ̄_zz/dz = ρ g − 4 τ_w / D makes the wall shear saturate at ρ g D / 4 whatever K is.

# %%
ifd_side = (z > z_bottom + 3 * w)                 # above the bottom's own IFD
tau_w = np.trapezoid(t[:, :, 2] * r[:, None], r, axis=0) / R
sigma_w = -np.trapezoid(t[:, :, 0] * r[:, None], r, axis=0) / R

edges = np.linspace(z_bottom, top, 21)
e_r = c.point[side, :2] / R
f_n = -np.einsum("ij,ij->i", c.force[side, :2], e_r)
area = 2 * np.pi * R * np.diff(edges)
tau_bins = np.histogram(c.point[side, 2], edges, weights=c.force[side, 2])[0] / area
sigma_bins = np.histogram(c.point[side, 2], edges, weights=f_n)[0] / area

fig, ax = plt.subplots(figsize=(5.5, 4.2), constrained_layout=True)
ax.plot(tau_w[ifd_side], depth[ifd_side], label="τ_w from the IFD")
ax.plot(sigma_w[ifd_side], depth[ifd_side], label="σ_w from the IFD")
ax.stairs(tau_bins, top - edges, orientation="horizontal", color="C0", ls=":", label="τ_w, wall contacts binned")
ax.stairs(sigma_bins, top - edges, orientation="horizontal", color="C1", ls=":", label="σ_w, wall contacts binned")
ax.plot(mu_wall * K * janssen(depth, K)[ifd_side], depth[ifd_side], "k--", lw=0.8, label="μ_w K σ_zz (Janssen)")
ax.axvline(rho_bulk * g * D / 4, color="0.6", lw=0.8, label="ρ g D / 4")
ax.set(xlabel="wall stress", ylabel="depth below the free surface")
ax.invert_yaxis()
ax.legend(fontsize=8)
fig

# %% [markdown]
# **How much of the wall friction is mobilised**: the ratio τ_w / σ_w along the wall, against the sliding
# friction μ_w = 0.5 (the Coulomb bound every wall contact obeys). The fit above determines only the
# product μ_w K of Janssen's law; the wall itself says how it splits: the mobilised friction τ_w / σ_w and
# the stress ratio σ_w / σ̄_zz (printed below). And the IFD in the (r, z) plane: it lives on the two walls
# only (r = R and the bottom), nowhere in the bulk.

# %%
fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), constrained_layout=True)
ok = ifd_side & (sigma_w > 0.05 * sigma_w.max())
axes[0].plot(tau_w[ok] / sigma_w[ok], depth[ok])
axes[0].axvline(mu_wall, color="0.5", ls="--", label="μ_w")
axes[0].set(xlabel="τ_w / σ_w", ylabel="depth below the free surface", xlim=(0, 0.6))
axes[0].invert_yaxis()
axes[0].legend()
t_norm = np.linalg.norm(t, axis=-1)
image = axes[1].pcolormesh(r, z, t_norm.T, shading="auto")
axes[1].axvline(R, color="w", lw=0.5)
axes[1].set(xlabel="r", ylabel="z", title="|t| (θ-averaged IFD)")
fig.colorbar(image, ax=axes[1])
saturated = ok & (depth > 2 * D)
print(f"below 2 D: μ_w K = {mu_wall * K:.3f} from the fit; mobilised friction τ_w / σ_w = "
      f"{tau_w[saturated].mean() / sigma_w[saturated].mean():.3f}, stress ratio σ_w / σ̄_zz = "
      f"{sigma_w[saturated].mean() / sigma_zz_mean[saturated].mean():.3f}, their product "
      f"{tau_w[saturated].mean() / sigma_zz_mean[saturated].mean():.3f}")
fig
