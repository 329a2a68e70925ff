# %% [markdown]
# # μ(I) from chute flows at several inclinations
#
# A granular layer flowing steadily down a rough incline at angle θ is the classical experiment behind the
# μ(I) rheology (GDR MiDi, Eur. Phys. J. E 14, 341 (2004); Silbert et al., Phys. Rev. E 64, 051302 (2001)):
# in steady uniform flow the momentum balance fixes the stress ratio −σ_xz/σ_zz = tan θ at every depth, the
# flow picks the shear rate that makes the local friction μ = |τ|/p match it, and plotting μ against the
# inertial number I = γ̇ d / √(p/ρ_p) for several inclinations traces the friction law, fitted here by
# Jop, Forterre & Pouliquen (Nature 441, 727 (2006)):
#
# $$\mu(I) = \mu_s + \frac{\mu_2 - \mu_s}{1 + I_0/I}.$$
#
# The scene is `cgbound.paper.scenes.inclined_chute`: 1300 flowing spheres (d = 1, m = 1) on a 10 × 10
# periodic rough base of fixed spheres of the same size, frictional spring-dashpot contacts (the paper's
# model ten times softer, e = 0.88, sliding friction 0.5), gravity tilted by θ. Each inclination was run with
# LAMMPS from rest (`scripts/make_rheology_chutes.py`): a spin-up, then frames with contacts every 0.5 time
# units over the averaging window. The depth profiles — averaged analytically over x and y and over the
# window's frames, Gaussian kernel w = d/2, standard errors from 8 block means
# (`CoarseGrain(..., errors="blocks")`) — are shipped in `cgbound/data/rheology_chutes.h5` (units d = m = g = 1).
# Set `RESIMULATE = True` to run the chutes again (about half an hour of CPU).

# %%
RESIMULATE = False

import tempfile
import numpy as np
import matplotlib.pyplot as plt
import cgbound as cg
from cgbound.paper import chute_rheology
from cgbound.paper.datasets import rheology_chutes

if RESIMULATE:
    frames_dir = tempfile.mkdtemp(prefix="cgbound-rheology-")
    for angle in chute_rheology.ANGLES:
        chute_rheology.simulate(angle, frames_dir)
    chutes = chute_rheology.profiles_from_frames(frames_dir)
else:
    chutes = rheology_chutes()

info = chutes[0].provenance
print(f"{info['lammps_version']}; {info['n_particles']} particles ({info['n_fixed']} fixed); spin-up "
      f"{info['spinup']:g}, window {info['window']:g} (frames every {info['frame_interval']:g}), seed {info['seed']}")
print("effects:", ", ".join(info["effects"]))
for c in chutes:
    print(c.summary())

# %% [markdown]
# **The windows are steady.** The kinetic energy of the flow (LAMMPS thermo, every time unit) rises from
# rest and levels off; over the averaging window (shaded) its mean changes by a few per cent at most between
# the two halves.

# %%
fig, ax = plt.subplots(figsize=(7, 3.2), constrained_layout=True)
for c in chutes:
    t, ke = c.kinetic_energy
    ax.plot(t, ke / (info["n_particles"] - info["n_fixed"]), lw=0.8, label=f"θ = {c.angle:g}°")
    drift = c.kinetic_energy_drift()
    print(f"theta = {c.angle:4g}: kinetic energy drift over the window {100 * drift:+.1f} %")
    assert abs(drift) < 0.05
ax.axvspan(info["spinup"], info["spinup"] + info["window"], color="0.85", label="averaging window")
ax.set_xlabel("t [√(d/g)]"); ax.set_ylabel("kinetic energy per flowing particle [m g d]")
ax.legend(fontsize=8, ncol=2)
plt.show()

# %% [markdown]
# **Depth profiles**: the downslope velocity V_x and the volume fraction φ. The bulk used for the checks
# and μ(I) (grey band for the steepest chute) starts 2 d above the top of the base (z = 0.5) and ends 2 d
# below the surface, where φ falls to half its bulk value.

# %%
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(8, 4), sharey=True, constrained_layout=True)
for c in chutes:
    v, ev = c.fields["velocity"][:, 0], c.errors["velocity"][:, 0]
    line, = ax1.plot(v, c.z, label=f"θ = {c.angle:g}°")
    ax1.fill_betweenx(c.z, v - 2 * ev, v + 2 * ev, color=line.get_color(), alpha=0.3)
    ax2.plot(c.fields["volume_fraction"], c.z, color=line.get_color(), label=f"θ = {c.angle:g}°")
bulk = chutes[-1].z[chutes[-1].bulk]
for ax in (ax1, ax2):
    ax.axhspan(bulk[0], bulk[-1], color="0.92", zorder=0)
ax1.set_xlabel("downslope velocity $V_x$ [√(g d)] (band: ±2 standard errors)"); ax1.set_ylabel("z [d]")
ax2.set_xlabel("volume fraction φ"); ax1.legend(fontsize=8)
plt.show()

# %% [markdown]
# **Check 1: the stress ratio is tan θ.** Steady uniform flow balances the weight of the layer above z in
# both directions, so −σ_xz/σ_zz = tan θ at every depth above the base (`cg.stress_ratio` on a Result; here
# from the shipped σ). The error bar of the ratio is propagated from the block errors of σ_xz and σ_zz as
# if independent (they are positively correlated, so this overestimates it), and that of a depth mean is
# bounded by the mean of the nodes' errors (neighbouring nodes are correlated).

# %%
fig, ax = plt.subplots(figsize=(5.5, 4.2), constrained_layout=True)
for c in chutes:
    ratio, error = c.stress_ratio()
    b = c.bulk
    line, = ax.plot(ratio[b], c.z[b], label=f"θ = {c.angle:g}°")
    ax.fill_betweenx(c.z[b], ratio[b] - 2 * error[b], ratio[b] + 2 * error[b], color=line.get_color(), alpha=0.3)
    ax.axvline(c.tan_angle, color=line.get_color(), ls=":", lw=1.5)
    mean, bound = c.bulk_mean(None, ratio, error)
    print(f"theta = {c.angle:4g}: bulk -sigma_xz/sigma_zz = {mean:.4f} ± {bound:.4f}, tan theta = {c.tan_angle:.4f} "
          f"({(mean - c.tan_angle) / bound:+.1f} standard errors)")
    assert abs(mean - c.tan_angle) < 2 * bound
ax.set_xlabel(r"$-\sigma_{xz}/\sigma_{zz}$ in the bulk (band ±2 s.e.; dotted: tan θ)"); ax.set_ylabel("z [d]")
ax.legend(fontsize=8)
plt.show()

# %% [markdown]
# **Check 2: the shear rate is the velocity profile's slope.** `shear_rate` γ̇ = √(2 D′:D′) comes from the
# analytic kernel gradient of the momentum and density (no finite differences); in this simple shear it is
# |∂V_x/∂z|, which we compare with central differences of the V_x profile (node spacing 0.1 d = w/5, so the
# differences are accurate to ~(h/w)²/6 ≈ 0.7 % of the local curvature term).

# %%
fig, ax = plt.subplots(figsize=(5.5, 4.2), constrained_layout=True)
for c in chutes:
    b = c.bulk
    difference = np.gradient(c.fields["velocity"][:, 0], c.z)
    rate = c.fields["shear_rate"]
    line, = ax.plot(rate[b], c.z[b], label=f"θ = {c.angle:g}°: shear_rate")
    ax.plot(np.abs(difference[b]), c.z[b], "k:", lw=1)
    gap = np.max(np.abs(rate[b] - np.abs(difference[b]))) / rate[b].max()
    print(f"theta = {c.angle:4g}: max |shear_rate - |dV_x/dz|| in the bulk = {100 * gap:.2f} % of the largest shear rate")
    assert gap < 0.02
ax.plot([], [], "k:", label=r"$|\Delta V_x / \Delta z|$ (central differences)")
ax.set_xlabel(r"shear rate $\dot\gamma$ [√(g/d)]"); ax.set_ylabel("z [d]"); ax.legend(fontsize=8)
plt.show()

# %% [markdown]
# **μ(I).** Every bulk node of every chute gives a (I, μ) pair from the `inertial_number` and `friction`
# fields (small dots); the bulk means with their error bounds (large markers) are fitted with the
# Jop–Forterre–Pouliquen law (`cg.fit_mu_of_i`, weighted by the error bounds; its parameter errors are
# therefore conservative).

# %%
means = np.array([[*c.bulk_mean("inertial_number"), *c.bulk_mean("friction")] for c in chutes])
i_bulk, ei_bulk, mu_bulk, emu_bulk = means.T
fit = cg.fit_mu_of_i(i_bulk, mu_bulk, sigma=emu_bulk)
print(fit)
print(f"mu_s = {fit.mu_s:.3f} ± {fit.errors[0]:.3f}, mu_2 = {fit.mu_2:.3f} ± {fit.errors[1]:.3f}, "
      f"I_0 = {fit.i_0:.3f} ± {fit.errors[2]:.3f}")
assert np.all(np.diff(i_bulk) > 0) and np.all(np.diff(mu_bulk) > 0)   # steeper chutes flow faster and rub harder
assert 0.2 < fit.mu_s < mu_bulk.min() and fit.mu_2 > mu_bulk.max() and fit.i_0 > 0

fig, ax = plt.subplots(figsize=(6, 4.2), constrained_layout=True)
for c, i, ei, mu, emu in zip(chutes, i_bulk, ei_bulk, mu_bulk, emu_bulk):
    b = c.bulk
    line, = ax.plot(c.fields["inertial_number"][b], c.fields["friction"][b], ".", ms=2, alpha=0.5)
    ax.errorbar(i, mu, xerr=ei, yerr=emu, fmt="o", color=line.get_color(), ms=7, capsize=3,
                label=f"θ = {c.angle:g}° (bulk mean)")
grid = np.linspace(1e-3, 1.2 * i_bulk.max(), 200)
ax.plot(grid, fit(grid), "k-", label=(rf"$\mu_s$ = {fit.mu_s:.3f}, $\mu_2$ = {fit.mu_2:.3f}, "
                                        rf"$I_0$ = {fit.i_0:.3f}"))
ax.axhline(fit.mu_s, color="0.6", ls="--", lw=1)
ax.set_xlabel("inertial number I"); ax.set_ylabel(r"friction $\mu = |\tau|/p$"); ax.legend(fontsize=8)
plt.show()

# %% [markdown]
# **Structure against depth.** The coordination number Z (contacts per particle, boundary contacts counted
# once) and the anisotropy of the normalised fabric Φ = F / tr F, a = √(3/2 Φ′:Φ′) (0 for isotropic
# contact directions), with its shear component Φ_xz: contacts line up along the compression direction
# (Φ_xz < 0 with x downslope), less so and with fewer contacts the faster the flow.

# %%
fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(10, 4), sharey=True, constrained_layout=True)
for c in chutes:
    inside = (c.z > 0.5) & (c.z < c.surface)
    z_err = c.errors["coordination_number"]
    line, = ax1.plot(c.fields["coordination_number"][inside], c.z[inside], label=f"θ = {c.angle:g}°")
    ax1.fill_betweenx(c.z[inside], (c.fields["coordination_number"] - 2 * z_err)[inside],
                      (c.fields["coordination_number"] + 2 * z_err)[inside], color=line.get_color(), alpha=0.3)
    phi, anisotropy = c.fabric_anisotropy()
    ax2.plot(anisotropy[inside], c.z[inside], color=line.get_color())
    ax3.plot(phi[inside, 0, 2], c.z[inside], color=line.get_color())
    print(f"theta = {c.angle:4g}: bulk coordination number {c.bulk_mean('coordination_number')[0]:.2f}, "
          f"fabric anisotropy {np.mean(anisotropy[c.bulk]):.3f}, Phi_xz {np.mean(phi[c.bulk, 0, 2]):+.3f}")
ax1.set_xlabel("coordination number Z"); ax1.set_ylabel("z [d]"); ax1.legend(fontsize=8)
ax2.set_xlabel(r"fabric anisotropy $\sqrt{3/2\,\Phi':\Phi'}$"); ax3.set_xlabel(r"$\Phi_{xz}$")
plt.show()
coordination = [c.bulk_mean("coordination_number")[0] for c in chutes]
assert np.all(np.diff(coordination) < 0)   # faster flows have fewer contacts
