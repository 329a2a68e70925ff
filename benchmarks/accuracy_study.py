"""What accuracy costs in time: the sweeps behind benchmarks/accuracy_vs_time.py and notebook 04.

Each setting coarse-grains one dense granular snapshot (density, bulk and boundary contact stress) on
an XYZ grid and is compared with a converged reference: the Gaussian of the same width cut off at
REFERENCE_CUTOFF widths (its neglected tail is ~1e-20 of the mass), exact erf line integrals.

Measures (all relative):
  stress_err  L2 norm over the nodes of (sigma_b + sigma_w) - reference, over the reference's norm.
              Spacing sweep: against the same kernel on the finest grid, the coarse grid interpolated
              (trilinear) onto the finest grid's nodes: what a coarse grid loses between its nodes.
              Kernel sweep: Lucy and Heaviside against the Gaussian of matched second moment, i.e. how
              far a different kernel of the same resolution is, not a discretisation error.
  line_err    line sweep only: against exact erf line integrals at the same cutoff (the quadrature
              error alone). Without the line_quadrature option the Gauss-Legendre rows are emulated from
              point scatters at the nodes (same numbers as the option gives; no time, no residual).
  mass_err    |sum(rho) dV - total flowing mass| / total mass (docs/theory.md, "Mass").
  virial_err  |integral of (sigma_b + sigma_w) dV + sum f_ij r_ij + sum f_ik a_ik|_F / |sum f r|_F (3.2).
  mb_resid    largest relative momentum-balance residual at random points (3.3,
              cgbound.momentum_balance_residual; NaN for the Heaviside kernel, which has no gradient).
  time_s      median wall time of cgbound.coarse_grain for the three fields over --repeat rounds that
              call every setting once each (interleaved, after the untimed call that measured the
              errors); time_min_s the fastest of them (less sensitive to a shared machine).

Kernel matching: per-axis second moments equal w^2. For the 3D Lucy kernel <r^2> = c^2 / 4, so
c = 2 sqrt(3) w ~ 3.46 w; for the uniform ball <r^2> = 3 R^2 / 5, so R = sqrt(5) w ~ 2.24 w.
"""
import csv
import inspect
import math
import os
import statistics
import time

import numpy as np

import cgbound as cg
from cgbound.kernels import DEFAULT_GAUSSIAN_CUTOFF
from common import cpu_model  # benchmarks/ is on sys.path for the scripts and notebook 04

REFERENCE_CUTOFF = 10.0
FIELDS = ("density", "contact_stress", "boundary_stress")
LUCY_CUTOFF_PER_WIDTH = 2.0 * math.sqrt(3.0)
HEAVISIDE_RADIUS_PER_WIDTH = math.sqrt(5.0)

FULL = dict(cutoffs=(2, 3, 4, 5, 6, 8), line_nodes=(1, 2, 3, 4, 8), w_over_d=(1 / 8, 1 / 4, 1 / 2, 1, 2),
            h_over_w=(0.25, 0.5, 1, 2), base_w_over_d=0.5, base_h_over_w=1.0, size=10.0, mb_points=200)
QUICK = dict(FULL, w_over_d=(1 / 8, 1 / 2, 2), h_over_w=(0.5, 1, 2), size=5.0, mb_points=60)
COLUMNS = ("sweep", "setting", "w_over_d", "h_over_w", "cutoff_over_w", "time_s", "time_min_s", "stress_err", "line_err",
           "mass_err", "virial_err", "mb_resid")


def machine_line():
    threads = os.environ.get("OMP_NUM_THREADS", str(os.cpu_count()))
    return (f"CPU: {cpu_model()}; cores: {os.cpu_count()}; OMP_NUM_THREADS: {threads}; "
            f"OpenMP build: {cg.have_openmp()}; cgbound {cg.__version__}")


def has_line_quadrature():
    """Whether this cgbound's Gaussian takes line_quadrature= (Gauss-Legendre along contact segments)."""
    return "line_quadrature" in inspect.signature(cg.Gaussian).parameters


def gaussian(w, cutoff_over_w, normalize="full", line="exact"):
    kw = {} if line == "exact" and not has_line_quadrature() else {"line_quadrature": line}
    return cg.Gaussian(w, cutoff=cutoff_over_w * w, normalize=normalize, **kw)


# --- data -----------------------------------------------------------------------------------

def load_snapshot(data=None, frame=-1, size=10.0, seed=0):
    """(snapshot, particle diameter): the generated packing, or one frame of a cgbound HDF5 file."""
    if data is None:
        from packing import dense_packing
        snap = dense_packing(size=size, seed=seed)
    else:
        frames = cg.readers.HDF5Snapshots(data)
        snap = frames[frame]
    flow = snap.flowing
    d = 2.0 * float(np.median(snap.radii[flow])) if snap.radii is not None else 1.0
    return snap, d


def make_grid(snap, h, pad):
    """XYZ grid of spacing ~h over the box, padded by ``pad`` along non-periodic axes (whole support inside)."""
    box = snap.box
    periodic = np.array(box.periodic)
    lower = np.where(periodic, box.lower, box.lower - pad)
    upper = np.where(periodic, box.upper, box.upper + pad)
    shape = tuple(max(1, int(round(L / h))) for L in upper - lower)
    return cg.Grid(cg.Box(lower, upper, periodic=box.periodic), shape)


def contact_virial(snap):
    """-sum f_ij (x) r_ij - sum f_ik (x) a_ik: what the contact stress must integrate to (docs/theory.md, "Virial")."""
    bulk, boundary = snap.split_contacts()
    return -(np.einsum("ma,mb->ab", bulk["force"], bulk["branch"])
             + np.einsum("ma,mb->ab", boundary["force"], boundary["branch"]))


def mb_points(snap, n, seed=1):
    rng = np.random.default_rng(seed)
    return snap.box.lower + rng.uniform(0.0, 1.0, (n, snap.dim)) * snap.box.lengths


def interleaved_times(jobs, repeat):
    """Wall times of ``repeat`` rounds over all jobs, one call of each per round.

    Interleaving spreads a shared machine's load bursts over all settings alike, so settings compared
    in one run see the same conditions (timing each setting's repeats back to back does not).
    """
    times = [[] for _ in jobs]
    for _ in range(max(1, repeat)):
        for k, fn in enumerate(jobs):
            if fn is None:     # nothing to time (an emulated setting)
                continue
            start = time.perf_counter()
            fn()
            times[k].append(time.perf_counter() - start)
    return times


def contact_stress(result):
    s = result.contact_stress + result.boundary_stress
    return s.reshape(-1, s.shape[-1] * s.shape[-2])


def rel_l2(a, b):
    ref = np.linalg.norm(b)
    return float(np.linalg.norm(a - b) / ref) if ref > 0 else float(np.linalg.norm(a))


def interpolate(grid, values, points):
    """Trilinear interpolation of node values (shape grid.shape + (k,)) at points; periodic axes wrap."""
    values = values.reshape(grid.shape + (-1,))
    out = np.zeros((len(points), values.shape[-1]))
    lo_idx, frac = [], []
    for d in range(grid.dim):
        n, h = grid.shape[d], grid.spacing[d]
        f = (points[:, d] - grid.box.lower[d]) / h - 0.5
        i0 = np.floor(f).astype(np.int64)
        t = f - i0
        if not grid.box.periodic[d]:
            t = np.where(i0 < 0, 0.0, np.where(i0 >= n - 1, 1.0, t))
            i0 = np.clip(i0, 0, max(n - 2, 0))
        lo_idx.append(i0)
        frac.append(t)
    for corner in range(2 ** grid.dim):
        weight = np.ones(len(points))
        idx = []
        for d in range(grid.dim):
            up = (corner >> d) & 1
            weight = weight * (frac[d] if up else 1.0 - frac[d])
            idx.append((lo_idx[d] + up) % grid.shape[d])
        out += weight[:, None] * values[tuple(idx)]
    return out


def emulated_gl_stress(snap, grid, kernel, n):
    """sigma_b + sigma_w with n-point Gauss-Legendre along each contact segment, from point scatters.

    Each contact becomes n point sources at r_i - s_k b (b the branch vector, s_k the Gauss-Legendre nodes
    on [0, 1]) carrying weight_k * (-f (x) b). This is the rule a C implementation of line_quadrature=n
    evaluates, so its error is the quadrature error whatever the implementation; its time is not
    representative (n separate point scatters from Python), so the study reports no time for it.
    Uses the package's private point-scatter entry point (cgbound._engine.scatter_points).
    """
    from cgbound import _engine
    nodes, weights = np.polynomial.legendre.leggauss(n)
    s, wts = 0.5 * (nodes + 1.0), 0.5 * weights
    bulk, boundary = snap.split_contacts()
    start = np.concatenate([snap.positions[bulk["i"]], snap.positions[boundary["i"]]])
    branch = np.concatenate([bulk["branch"], boundary["branch"]])
    force = np.concatenate([bulk["force"], boundary["force"]])
    values = -np.einsum("ma,mb->mab", force, branch).reshape(len(force), -1)
    pts = np.concatenate([start - sk * branch for sk in s])
    vals = np.concatenate([wk * values for wk in wts])
    return _engine.scatter_points(_engine.core_target(grid, snap.box), _engine.core_kernel(kernel, grid.avg_extent),
                                  pts, vals)


# --- the study ------------------------------------------------------------------------------

class Study:
    """Holds the snapshot, references per (w, h) and the rows measured so far."""

    def __init__(self, snap, diameter, repeat=3, mb_count=200, log=print):
        self.snap, self.d, self.repeat, self.log = snap, diameter, repeat, log
        self.total_mass = float(snap.masses[snap.flowing].sum())
        self.virial = contact_virial(snap)
        self.points = mb_points(snap, mb_count)
        self.grids, self.refs, self.rows, self.jobs = {}, {}, [], []

    def grid(self, w, h_over_w):
        key = (w, h_over_w)
        if key not in self.grids:
            self.grids[key] = make_grid(self.snap, h_over_w * w, REFERENCE_CUTOFF * w)
        return self.grids[key]

    def reference(self, w, h_over_w):
        key = (w, h_over_w)
        if key not in self.refs:
            grid = self.grid(w, h_over_w)
            out = cg.coarse_grain(self.snap, grid, gaussian(w, REFERENCE_CUTOFF), fields=FIELDS)
            self.refs[key] = contact_stress(out)
        return self.refs[key]

    def measure(self, sweep, setting, kernel, w, h_over_w, cutoff_over_w, compare=None, line_ref=None):
        """Check one setting (timed later, see time_all); ``compare(out)`` overrides the same-node comparison."""
        grid = self.grid(w, h_over_w)
        job = (lambda: cg.coarse_grain(self.snap, grid, kernel, fields=FIELDS))
        out = job()    # also the warm-up call of the timing
        dv = float(np.prod(grid.spacing))
        stress = contact_stress(out)
        err = compare(out) if compare else rel_l2(stress, self.reference(w, h_over_w))
        mass_err = abs(out.density.sum() * dv - self.total_mass) / self.total_mass
        integral = stress.sum(axis=0).reshape(self.virial.shape) * dv
        virial_err = float(np.linalg.norm(integral - self.virial) / np.linalg.norm(self.virial))
        if kernel.differentiable:
            mb = float(cg.momentum_balance_residual(self.snap, self.points, kernel).relative.max())
        else:
            mb = float("nan")
        row = dict(sweep=sweep, setting=setting, w_over_d=w / self.d, h_over_w=h_over_w, cutoff_over_w=cutoff_over_w,
                   time_s=float("nan"), time_min_s=float("nan"), stress_err=err, line_err=rel_l2(stress, line_ref) if line_ref is not None else float("nan"),
                   mass_err=float(mass_err), virial_err=virial_err, mb_resid=mb)
        self.rows.append(row)
        self.jobs.append(job)
        self.log(format_row(row))
        return row, stress

    def measure_emulated(self, sweep, setting, n, w, h_over_w, cutoff_over_w, line_ref):
        """Errors of n-point Gauss-Legendre line integrals emulated from point scatters (no time)."""
        grid = self.grid(w, h_over_w)
        stress = emulated_gl_stress(self.snap, grid, gaussian(w, cutoff_over_w), n)
        dv = float(np.prod(grid.spacing))
        integral = stress.sum(axis=0).reshape(self.virial.shape) * dv
        row = dict(sweep=sweep, setting=setting, w_over_d=w / self.d, h_over_w=h_over_w, cutoff_over_w=cutoff_over_w,
                   time_s=float("nan"), time_min_s=float("nan"), stress_err=rel_l2(stress, self.reference(w, h_over_w)),
                   line_err=rel_l2(stress, line_ref), mass_err=float("nan"),
                   virial_err=float(np.linalg.norm(integral - self.virial) / np.linalg.norm(self.virial)),
                   mb_resid=float("nan"))
        self.rows.append(row)
        self.jobs.append(None)
        self.log(format_row(row))
        return row

    def time_all(self):
        """Median and fastest of ``repeat`` interleaved timed runs per row."""
        for row, times in zip(self.rows, interleaved_times(self.jobs, self.repeat)):
            if times:
                row["time_s"], row["time_min_s"] = statistics.median(times), min(times)


def run_study(snap, diameter, config=FULL, repeat=3, sweeps=("cutoff", "line", "kernel", "spacing"), log=print):
    """Run the sweeps; returns the list of row dicts (COLUMNS)."""
    st = Study(snap, diameter, repeat=repeat, mb_count=config["mb_points"], log=log)
    w0, h0 = config["base_w_over_d"] * diameter, config["base_h_over_w"]
    c0 = DEFAULT_GAUSSIAN_CUTOFF
    log("# errors (timing follows):")
    log(header())
    if "cutoff" in sweeps:
        for norm in ("full", "truncated"):
            for c in config["cutoffs"]:
                st.measure("cutoff", f"Gaussian c={c:g}w {norm}", gaussian(w0, c, norm), w0, h0, c)
    if "line" in sweeps:
        native = has_line_quadrature()
        if not native:
            log("# line sweep: this cgbound's Gaussian has no line_quadrature= option; Gauss-Legendre errors are "
                "emulated from point scatters (rows 'GLn emulated', no time)")
        for wd in config["w_over_d"]:
            w = wd * diameter
            _, exact = st.measure("line", f"exact erf w={wd:g}d", gaussian(w, c0), w, h0, c0)
            for n in config["line_nodes"]:
                if native:
                    st.measure("line", f"GL{n} w={wd:g}d", gaussian(w, c0, line=n), w, h0, c0, line_ref=exact)
                else:
                    st.measure_emulated("line", f"GL{n} emulated w={wd:g}d", n, w, h0, c0, exact)
    if "kernel" in sweeps:
        st.measure("kernel", f"Gaussian c={c0:g}w", gaussian(w0, c0), w0, h0, c0)
        st.measure("kernel", "Lucy c=2sqrt(3)w", cg.Lucy(LUCY_CUTOFF_PER_WIDTH * w0), w0, h0, LUCY_CUTOFF_PER_WIDTH)
        st.measure("kernel", "Heaviside R=sqrt(5)w", cg.Heaviside(HEAVISIDE_RADIUS_PER_WIDTH * w0), w0, h0,
                   HEAVISIDE_RADIUS_PER_WIDTH)
    if "spacing" in sweeps:
        # the same kernel on the finest grid is the reference here: what a coarser grid loses between its
        # nodes (interpolated onto the finest nodes), apart from the cutoff error seen above
        spacings = sorted(config["h_over_w"])
        fine_grid = st.grid(w0, spacings[0])
        fine_nodes = fine_grid.coordinates.reshape(-1, snap.dim)
        fine = {}
        for hw in spacings:
            grid = st.grid(w0, hw)
            compare = (lambda out, g=grid: rel_l2(interpolate(g, contact_stress(out), fine_nodes),
                                                   fine.setdefault("ref", contact_stress(out))))
            st.measure("spacing", f"h={hw:g}w c={c0:g}w", gaussian(w0, c0), w0, hw, c0, compare=compare)
    log(f"# timing: {repeat} interleaved rounds over the {len(st.rows)} settings")
    st.time_all()
    log(table(st.rows))
    return st.rows


# --- presentation ---------------------------------------------------------------------------

def header():
    return (f"{'sweep':<8}{'setting':<26}{'w/d':>7}{'h/w':>6}{'c/w':>6}{'time ms':>10}{'min ms':>9}{'stress err':>12}"
            f"{'line err':>10}{'mass err':>10}{'virial err':>11}{'mb resid':>10}")


def ms(seconds):
    return f"{1e3 * seconds:.1f}" if np.isfinite(seconds) else "-"


def format_row(r):
    def g(x):
        return f"{x:.1e}" if np.isfinite(x) else "-"
    return (f"{r['sweep']:<8}{r['setting']:<26}{r['w_over_d']:>7.3g}{r['h_over_w']:>6.3g}{r['cutoff_over_w']:>6.3g}"
            f"{ms(r['time_s']):>10}{ms(r['time_min_s']):>9}{g(r['stress_err']):>12}{g(r['line_err']):>10}{g(r['mass_err']):>10}"
            f"{g(r['virial_err']):>11}{g(r['mb_resid']):>10}")


def table(rows):
    return "\n".join([header()] + [format_row(r) for r in rows])


def write_csv(rows, path):
    tmp = f"{path}.tmp"
    with open(tmp, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=COLUMNS)
        writer.writeheader()
        for r in rows:
            writer.writerow({k: r[k] for k in COLUMNS})
    os.replace(tmp, path)


def pareto_front(rows):
    """Rows no other row beats on both time and stress error (ties kept), sorted by time; untimed rows are left out."""
    rows = [r for r in rows if np.isfinite(r["time_s"])]
    front = [r for r in rows
             if not any((o["time_s"] <= r["time_s"] and o["stress_err"] <= r["stress_err"])
                        and (o["time_s"] < r["time_s"] or o["stress_err"] < r["stress_err"]) for o in rows)]
    return sorted(front, key=lambda r: r["time_s"])


def base_rows(rows, diameter_ratio, h_over_w):
    """Gaussian rows on the base grid and width: the candidates for the defaults."""
    return [r for r in rows if r["sweep"] in ("cutoff", "line")
            and math.isclose(r["w_over_d"], diameter_ratio) and math.isclose(r["h_over_w"], h_over_w)]


def plot(rows, path=None, config=FULL, title=""):
    """Time against stress error; the Pareto front of the base-grid Gaussian settings is marked."""
    import matplotlib
    if path is not None and not os.environ.get("DISPLAY") and "inline" not in matplotlib.get_backend():
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    floor = 1e-17
    fig, ax = plt.subplots(figsize=(7.5, 5))
    styles = {"cutoff": "o", "line": "s", "kernel": "^", "spacing": "D"}
    base_w = config["base_w_over_d"]
    for sweep, marker in styles.items():
        # the reference row of a sweep (error exactly 0) has no place on a log axis
        sel = [r for r in rows if r["sweep"] == sweep and r["stress_err"] > 0]
        groups = [(sel, sweep, 0.75)]
        if sweep == "line":   # other widths have other grids: shown, but faint and off the front
            groups = [([r for r in sel if math.isclose(r["w_over_d"], base_w)], f"line (w = {base_w:g} d)", 0.75),
                      ([r for r in sel if not math.isclose(r["w_over_d"], base_w)], "line (other w/d)", 0.2)]
        for group, label, alpha in groups:
            if group:
                ax.scatter([max(r["stress_err"], floor) for r in group], [1e3 * r["time_s"] for r in group],
                           marker=marker, label=label, alpha=alpha)
    cands = base_rows(rows, config["base_w_over_d"], config["base_h_over_w"])
    front = pareto_front(cands)
    if front:
        ax.plot([max(r["stress_err"], floor) for r in front], [1e3 * r["time_s"] for r in front], "k-", lw=1,
                drawstyle="steps-post", label="Pareto front (base grid)")
        for r in front:
            ax.annotate(r["setting"], (max(r["stress_err"], floor), 1e3 * r["time_s"]), fontsize=7,
                        xytext=(4, 2), textcoords="offset points")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("relative L2 error of the contact stress")
    ax.set_ylabel("wall time per frame (ms)")
    ax.set_title(title or "accuracy versus time")
    ax.legend(fontsize=8)
    fig.tight_layout()
    if path is not None:
        from cgbound.plot import save_figure
        save_figure(fig, path)       # the format of the extension (PNG, PDF, SVG), atomically
    return fig
