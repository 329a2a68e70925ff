"""mu(I) from steady chute flows at several inclinations (notebook 05): simulation and depth profiles.

:func:`simulate` runs :func:`cgbound.paper.scenes.inclined_chute` with LAMMPS and writes its frames;
:class:`ChuteProfiles` coarse grains them into depth profiles (averaged over x, y and time, with
standard errors from block means); :func:`write_profiles` / :func:`read_profiles` store the profiles
of all inclinations in one small HDF5 file (the shipped ``rheology_chutes.h5``).
"""
import json
import os
import shutil
import tempfile
import time

import numpy as np

#: the run: spin-up from rest, then frames every INTERVAL over WINDOW (time units sqrt(d / g))
SPINUP, WINDOW, INTERVAL, SEED = 300.0, 100.0, 0.5, 17
#: the shipped inclinations (degrees)
ANGLES = (22.0, 23.5, 25.0, 26.5)


def frames_path(frames_dir, angle):
    return os.path.join(frames_dir, f"chute_{float(angle):g}deg.h5")


def _lammps_version(workdir):
    try:
        with open(os.path.join(workdir, "log.lammps")) as f:
            return f.readline().strip()
    except OSError:
        return "unknown"


def _cpu(usage):
    return usage.ru_utime + usage.ru_stime


def simulate(angle, frames_dir, spinup=SPINUP, window=WINDOW, interval=INTERVAL, seed=SEED, workdir=None,
             executable=None):
    """Run the chute inclined at ``angle`` degrees with LAMMPS; write its frames (cgbound HDF5, with the
    provenance and the kinetic energy of the flow at every time unit) to :func:`frames_path`; returns the path."""
    import resource   # CPU time of LAMMPS (a child process); POSIX only, like running lmp here

    from ..readers.hdf5 import write_snapshots
    from .scenes import Frames, Run, inclined_chute, run_scene
    scene = inclined_chute(angle, seed=seed)
    count = int(round(window / interval)) + 1
    own = workdir is None
    workdir = tempfile.mkdtemp(prefix=f"cgbound-{scene.name}-") if own else workdir
    os.makedirs(frames_dir, exist_ok=True)
    try:
        start, children = time.process_time(), resource.getrusage(resource.RUSAGE_CHILDREN)
        run = run_scene(scene, [Run(spinup, thermo_every=1.0), Frames(count, interval)], workdir=workdir,
                        executable=executable)
        info = {"script": "scripts/make_rheology_chutes.py simulate", "angle_deg": float(angle), "seed": seed,
                "spinup": spinup, "window": window, "frame_interval": interval, "scene": scene.name,
                "n_particles": scene.n_particles, "n_fixed": int(scene.fixed.sum()), "effects": list(scene.effects),
                "engine": "LAMMPS", "lammps_version": _lammps_version(workdir),
                "lammps_wall_time_s": round(run.wall_time, 1),
                "lammps_cpu_time_s": round(_cpu(resource.getrusage(resource.RUSAGE_CHILDREN)) - _cpu(children), 1),
                "python_cpu_time_s": round(time.process_time() - start, 1),
                "kinetic_energy_time": run.thermo["time"].tolist(),
                "kinetic_energy": run.thermo["kinetic_energy"].tolist(), "input_script": run.input_script}
        path = frames_path(frames_dir, angle)
        write_snapshots(path, run.snapshots, provenance=info)
    finally:
        if own:
            shutil.rmtree(workdir, ignore_errors=True)
    return path


#: the fields of the shipped profiles (each with its standard error from block means)
PROFILE_FIELDS = ("density", "volume_fraction", "velocity", "velocity_gradient", "shear_rate", "stress", "pressure",
                  "friction", "inertial_number", "fabric", "coordination_number")
#: the bulk of the flow: this far (in d) above the top of the base and below the free surface
BULK_MARGIN = 2.0


class ChuteProfiles:
    """Depth profiles of one steady chute flow, averaged over x, y (analytically) and time, with block errors.

    Parameters
    ----------
    angle : float
        Inclination in degrees (gravity (sin, 0, -cos)).
    width : float
        Gaussian coarse-graining width w (default d / 2: smooth over the layering, sharp on the flow depth).
    spacing : float
        Distance between profile nodes.
    n_blocks : int
        Blocks of consecutive frames for the standard errors (``CoarseGrain(errors="blocks")``).

    Notes
    -----
    After :meth:`run` (or :func:`read_profiles`): ``z`` the node heights; ``fields`` and ``errors``
    ({name: (nz, ...) array}: the profiles and their standard errors; stresses tension-positive, the
    paper's convention); ``n_frames``; ``provenance`` (dict: how the frames were made);
    ``kinetic_energy`` ((time, energy) of the flow from t = 0). :attr:`surface` is where the volume
    fraction falls to half its bulk median, :attr:`bulk` the nodes at least BULK_MARGIN above the top
    of the base (z = 0.5) and below the surface.
    """

    def __init__(self, angle, width=0.5, spacing=0.1, n_blocks=8):
        from .._validate import positive_number
        self.angle = float(angle)
        if not (np.isfinite(self.angle) and 0 < self.angle < 90):
            raise ValueError(f"angle: expected an inclination in degrees between 0 and 90, got {angle!r}")
        self.width = positive_number(width, "width")
        self.spacing = positive_number(spacing, "spacing")
        if isinstance(n_blocks, bool) or not isinstance(n_blocks, (int, np.integer)) or n_blocks < 2:
            raise ValueError(f"n_blocks: expected an integer >= 2, got {n_blocks!r}")
        self.n_blocks = int(n_blocks)
        self.provenance, self.kinetic_energy = {}, (np.zeros(0), np.zeros(0))

    def run(self, frames):
        """Coarse grain ``frames`` (a sequence of cgbound Snapshots of this chute); returns self."""
        from ..box import Box
        from ..coarse import CoarseGrain
        from ..grid import Grid
        from ..kernels import Gaussian
        if not (hasattr(frames, "__len__") and hasattr(frames, "__getitem__")):
            raise TypeError(f"frames: expected a sequence of cg.Snapshot (a list or a reader), got {type(frames).__name__}")
        if len(frames) < self.n_blocks:
            raise ValueError(f"frames: expected at least n_blocks = {self.n_blocks} frames, got {len(frames)}")
        first = frames[0]
        top = first.positions[first.flowing, 2].max()
        lo, hi = -1.0, top + 2.0
        n = int(np.ceil((hi - lo) / self.spacing))
        lower, upper = np.array(first.box.lower, float), np.array(first.box.upper, float)
        lower[2], upper[2] = lo, lo + n * self.spacing
        grid = Grid(Box(lower, upper, periodic=first.box.periodic), (1, 1, n), average=("x", "y"))
        cg = CoarseGrain(frames, grid, Gaussian(self.width), fields=PROFILE_FIELDS, errors="blocks",
                         n_blocks=self.n_blocks).run()
        r = cg.results
        self.z = grid.axis_coordinates[-1]
        self.fields = {name: np.asarray(r[name]).reshape((n,) + np.shape(r[name])[3:]) for name in PROFILE_FIELDS}
        self.errors = {name: np.asarray(r.errors[name]).reshape(self.fields[name].shape) for name in PROFILE_FIELDS}
        self.block_correlation = {name: float(v) for name, v in r.block_correlation.items()}
        self.n_frames = len(frames)
        self.kernel = repr(Gaussian(self.width))
        self.provenance = json.loads(frames.provenance) if hasattr(frames, "provenance") else {}
        self.kinetic_energy = (np.asarray(self.provenance.get("kinetic_energy_time", []), float),
                               np.asarray(self.provenance.get("kinetic_energy", []), float))
        return self

    # -- what the checks and figures read --------------------------------------------------------------
    @property
    def surface(self):
        """Height where the volume fraction falls to half its median in the flow (linear between nodes)."""
        phi = self.fields["volume_fraction"]
        inside = self.z > 0.5 + BULK_MARGIN
        half = 0.5 * np.median(phi[inside & (phi > 0.5 * phi.max())])
        k = np.flatnonzero(phi >= half)[-1]
        # refine linearly between the last node at or above half and the next one
        return float(self.z[k] + (self.z[k + 1] - self.z[k]) * (phi[k] - half) / (phi[k] - phi[k + 1]))

    @property
    def bulk(self):
        """Nodes at least BULK_MARGIN above the top of the base (z = 0.5) and below the surface (bool mask)."""
        return (self.z >= 0.5 + BULK_MARGIN) & (self.z <= self.surface - BULK_MARGIN)

    @property
    def tan_angle(self):
        """tan(angle): the stress ratio -sigma_xz / sigma_zz of steady uniform flow."""
        return float(np.tan(np.radians(self.angle)))

    def stress_ratio(self):
        """(-sigma_xz / sigma_zz, its standard error) at every node; the error propagated from the block errors
        of the two components as if they were independent (they are positively correlated, so this is an upper
        estimate of the error of the ratio)."""
        s, e = self.fields["stress"], self.errors["stress"]
        xz, zz, exz, ezz = s[:, 0, 2], s[:, 2, 2], e[:, 0, 2], e[:, 2, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = -xz / zz
            error = np.abs(ratio) * np.sqrt((exz / xz) ** 2 + (ezz / zz) ** 2)
        return ratio, error

    def bulk_mean(self, name, values=None, errors=None):
        """(depth mean over the bulk, an upper bound of its standard error: the bulk mean of the nodes' errors).

        Neighbouring nodes are correlated (within a kernel width), so the error of the depth mean is not
        the nodes' errors over sqrt(count); by the triangle inequality it is at most their mean."""
        values = self.fields[name] if values is None else values
        errors = self.errors[name] if errors is None else errors
        b = self.bulk
        return float(np.mean(values[b])), float(np.mean(errors[b]))

    def fabric_anisotropy(self):
        """(normalised fabric Phi = F / tr F (nz, 3, 3), anisotropy a = sqrt(3/2 Phi':Phi') (0 when isotropic)),
        NaN where there are no contacts."""
        f = self.fields["fabric"]
        trace = np.trace(f, axis1=1, axis2=2)
        with np.errstate(divide="ignore", invalid="ignore"):
            phi = f / trace[:, None, None]
        dev = phi - np.eye(3) / 3.0
        return phi, np.sqrt(1.5 * np.einsum("kab,kab->k", dev, dev))

    def kinetic_energy_drift(self):
        """Relative change of the flow's mean kinetic energy from the first to the second half of the averaging
        window (LAMMPS thermo every time unit): near 0 for a steady flow, > 0 for one still accelerating."""
        t, ke = self.kinetic_energy
        t0 = float(self.provenance["spinup"])
        t1 = t0 + float(self.provenance["window"])
        middle = 0.5 * (t0 + t1)
        first, second = ke[(t >= t0) & (t < middle)].mean(), ke[(t >= middle) & (t <= t1)].mean()
        return float((second - first) / (0.5 * (first + second)))

    def summary(self):
        ratio, error = self.stress_ratio()
        r, e = self.bulk_mean(None, ratio, error)
        mu, emu = self.bulk_mean("friction")
        i, ei = self.bulk_mean("inertial_number")
        return (f"theta = {self.angle:g} deg: surface z = {self.surface:.2f}, bulk {self.z[self.bulk][0]:.1f}.."
                f"{self.z[self.bulk][-1]:.1f}; -sigma_xz/sigma_zz = {r:.4f} +- {e:.4f} (tan theta = "
                f"{self.tan_angle:.4f}); mu = {mu:.4f} +- {emu:.4f}, I = {i:.4f} +- {ei:.4f}; {self.n_frames} frames")


FORMAT = "cgbound-chute-rheology"


def write_profiles(path, chutes):
    """Write the profiles of several inclinations (a list of ChuteProfiles) to one HDF5 file, atomically."""
    import h5py

    from .._atomic import atomic_write

    def write(tmp):
        with h5py.File(tmp, "w") as f:
            f.attrs["format"] = FORMAT
            f.attrs["fields"] = json.dumps(PROFILE_FIELDS)
            f.attrs["convention"] = "tension"
            f.attrs["units"] = "d = m = g = 1 (flowing particle diameter and mass, gravity)"
            for c in sorted(chutes, key=lambda c: c.angle):
                g = f.create_group(f"{c.angle:g}deg")
                for name in ("angle", "width", "spacing", "n_blocks", "n_frames", "kernel"):
                    g.attrs[name] = getattr(c, name)
                g.attrs["block_correlation"] = json.dumps(c.block_correlation)
                g.attrs["provenance"] = json.dumps({k: v for k, v in c.provenance.items()
                                                    if not k.startswith("kinetic_energy")})
                g.create_dataset("z", data=c.z)
                g.create_dataset("kinetic_energy", data=np.stack(c.kinetic_energy))
                for name in PROFILE_FIELDS:
                    g.create_dataset(f"fields/{name}", data=c.fields[name])
                    g.create_dataset(f"errors/{name}", data=c.errors[name])
    return atomic_write(path, write)


def read_profiles(path):
    """The ChuteProfiles stored by :func:`write_profiles`, in order of inclination."""
    import h5py
    out = []
    with h5py.File(path, "r") as f:
        if f.attrs.get("format") != FORMAT:
            raise ValueError(f"path: {path!r} is not a {FORMAT} file")
        for key in f:
            g = f[key]
            c = ChuteProfiles(float(g.attrs["angle"]), width=float(g.attrs["width"]),
                              spacing=float(g.attrs["spacing"]), n_blocks=int(g.attrs["n_blocks"]))
            c.n_frames, c.kernel = int(g.attrs["n_frames"]), str(g.attrs["kernel"])
            c.block_correlation = json.loads(g.attrs["block_correlation"])
            c.provenance = json.loads(g.attrs["provenance"])
            c.z = g["z"][()]
            ke = g["kinetic_energy"][()]
            c.kinetic_energy = (ke[0], ke[1])
            c.fields = {name: g[f"fields/{name}"][()] for name in g["fields"]}
            c.errors = {name: g[f"errors/{name}"][()] for name in g["errors"]}
            out.append(c)
    return sorted(out, key=lambda c: c.angle)


def profiles_from_frames(frames_dir, angles=None, **options):
    """ChuteProfiles of every frames file written by :func:`simulate` in ``frames_dir`` (or of ``angles`` only)."""
    from ..readers.hdf5 import HDF5Snapshots
    out = []
    for name in sorted(os.listdir(frames_dir)):
        if name.startswith("chute_") and name.endswith("deg.h5"):
            frames = HDF5Snapshots(os.path.join(frames_dir, name))
            angle = json.loads(frames.provenance)["angle_deg"]
            if angles is not None and not any(abs(angle - a) < 1e-9 for a in angles):
                continue
            out.append(ChuteProfiles(angle, **options).run(frames))
    return sorted(out, key=lambda c: c.angle)
