# %% [markdown]
# # What accuracy costs in time
#
# The knobs that trade accuracy for time, swept on one dense granular snapshot and measured against a converged
# reference (the study code is `benchmarks/accuracy_study.py`; `python benchmarks/accuracy_vs_time.py` runs the
# full-size study and writes the CSV and the plot):
#
# * the Gaussian **cutoff** (2w to 8w) with both normalisations (`"full"`, `"truncated"`);
# * the **line integral** along contact segments: exact erf, or n-point Gauss–Legendre (n = 1, 2, 3, 4, 8) —
#   timed where this cgbound has `Gaussian(..., line_quadrature=n)`, otherwise its error is emulated from point
#   scatters at the Gauss–Legendre nodes (rows "GLn emulated", no time); crossed with the **width relative to
#   the particle diameter** w/d from 1/8 to 2 (the segment length over w is what a quadrature rule feels);
# * the **kernel**: Gaussian, Lucy and Heaviside at matched second moment (Lucy cutoff 2√3 w, Heaviside radius √5 w);
# * the **grid spacing** relative to w (the coarse grid interpolated onto the finest one).
#
# Data: a jammed polydisperse packing on a rough base of fixed particles (`benchmarks/packing.py`, fixed seed),
# periodic, with bulk and boundary contacts whose forces follow from the overlaps. Measures: relative L2 error
# of the contact stress σᵇ + σʷ, the [mass](../docs/theory.md#mass) and [virial](../docs/theory.md#virial) identities
# and the largest relative [momentum-balance residual](../docs/theory.md#momentum-balance)
# (`cg.momentum_balance_residual`). This notebook runs the `--quick` size.

# %%
import pathlib
import sys

# the study code lives in benchmarks/ (outside the package); find it from wherever the notebook runs
here = pathlib.Path.cwd().resolve()
root = next(p for p in (here, *here.parents) if (p / "benchmarks" / "accuracy_study.py").is_file())
sys.path.insert(0, str(root / "benchmarks"))
import accuracy_study as study

config = study.QUICK
snap, d = study.load_snapshot(size=config["size"])
print(study.machine_line())
print(snap, "; particle diameter d =", round(d, 4))
print("Gaussian line_quadrature option:", study.has_line_quadrature())

# %% [markdown]
# ## The sweeps
#
# One untimed warm-up and one timed run per setting here (the script takes `--repeat`); times at this size are
# milliseconds and noisy, so read them as orders of magnitude. The error columns are deterministic.

# %%
rows = study.run_study(snap, d, config, repeat=1, log=lambda line: None)
print(study.table(rows))

# %%
fig = study.plot(rows, config=config, title="accuracy versus time (quick size)")
front = study.pareto_front(study.base_rows(rows, config["base_w_over_d"], config["base_h_over_w"]))
print("Pareto front:", "; ".join(r["setting"] for r in front))

# %% [markdown]
# ## What the errors say (checked, so the notebook fails if the numbers change character)
#
# * The truncation error of the Gaussian falls like its neglected tail: each added width of cutoff buys
#   about two orders of magnitude, and 8 w reaches round-off against the 10 w reference.
# * The momentum-balance residual and the virial error follow the same tail (they measure the same thing
#   from different sides); the mass error of `normalize="truncated"` is far smaller (it renormalises the
#   prefactor) but its stress error and residual are not.
# * Lucy has no truncation error at all: its momentum-balance residual is at round-off.

# %%
cut = {(r["setting"].split()[-1], r["cutoff_over_w"]): r for r in rows if r["sweep"] == "cutoff"}
full = [cut[("full", c)]["stress_err"] for c in config["cutoffs"]]
assert all(b < a for a, b in zip(full, full[1:])), full           # more cutoff, less error
assert cut[("full", 8)]["stress_err"] < 1e-11
assert cut[("full", 8)]["mb_resid"] < 1e-11
for c in config["cutoffs"]:
    assert cut[("truncated", c)]["mass_err"] <= cut[("full", c)]["mass_err"]
lucy = next(r for r in rows if r["setting"].startswith("Lucy"))
assert lucy["mb_resid"] < 1e-12

# %% [markdown]
# ## Gauss–Legendre along the contacts
#
# The error of an n-point rule (against exact erf line integrals at the same cutoff, column `line err`) is set by
# the segment length over the width: bulk branch vectors are about one diameter long, so it is d/w that matters.
# Few nodes suffice for wide kernels, and no small n does for w ≪ d.

# %%
gl = {}
for r in rows:
    if r["sweep"] == "line" and r["setting"].startswith("GL"):
        gl[(round(r["w_over_d"], 4), int(r["setting"].split()[0][2:]))] = r["line_err"]
widths = sorted({k[0] for k in gl})
print("line err" + "".join(f"{'w/d=' + format(wd, 'g'):>12}" for wd in widths))
for n in config["line_nodes"]:
    print(f"GL{n:<6}" + "".join(f"{gl[(wd, n)]:>12.1e}" for wd in widths))
for wd in widths:
    assert gl[(wd, 1)] > gl[(wd, 8)]           # more nodes, less error
assert gl[(widths[0], 1)] > 0.1                 # one node cannot represent a segment 8 widths long
assert gl[(widths[-1], 2)] < 1e-4               # two nodes suffice for a segment half a width long

# %% [markdown]
# ## The rule
#
# **Cutoff.** The error a Gaussian cutoff c leaves is its neglected tail, the fraction Q(D/2, c²/2) of the
# kernel's mass beyond c w (D resolved axes): the measured stress error, virial error, mass error and
# momentum-balance residual all sit at that fraction (the residual up to about 1.3× it), at every w/d, while the
# work grows like c^D. `cg.gaussian_cutoff_for(rtol, dim)` returns the cheapest cutoff meeting a requested
# `rtol`. The default cutoff, 5 w, leaves 1.5e-5 on XYZ fields (3.7e-6 on 2D fields, 5.7e-7 on profiles): below
# the statistical noise of any DEM average, at about 0.7× the time of 6 w and 0.4× that of 8 w. To check a
# simulation's momentum balance to round-off, use 8 w or the Lucy kernel.
#
# **Line integrals.** n-point Gauss–Legendre meets the default cutoff's 1.5e-5 with 2 nodes for w ≥ 2d, 3 for
# w ≥ d, 4 for w ≥ d/2 and 8 for w ≥ d/4 (roughly n ≥ 1.5 L/w + 1 for a segment of length L); narrower
# kernels need the exact erf form.
#
# Below: the tail's prediction next to the measurement.

# %%
import cgbound as cg

print(f"{'cutoff':>7}{'predicted tail (3D)':>21}{'measured stress err':>21}{'measured mb resid':>19}")
for c in config["cutoffs"]:
    r = cut[("full", c)]
    print(f"{c:>6}w{cg.gaussian_tail_fraction(c, 3):>21.2e}{r['stress_err']:>21.2e}{r['mb_resid']:>19.2e}")
    # the tail predicts the measured errors (within a factor 1.5) until round-off takes over
    assert r["stress_err"] < 1.5 * cg.gaussian_tail_fraction(c, 3) + 1e-12
for rtol in (1e-2, 1e-4, 1e-6, 1e-8, 1e-12):
    print(f"rtol {rtol:.0e}: cutoff {cg.gaussian_cutoff_for(rtol, 3):.2f} w in 3D, "
          f"{cg.gaussian_cutoff_for(rtol, 1):.2f} w on a profile")
