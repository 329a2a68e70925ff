"""Run a scene with LAMMPS (the ``lmp`` executable) and collect what it produced."""
import os
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass, field

import numpy as np

from . import lammps as lmp_input

#: engine executables tried in order when none is given
LAMMPS_EXECUTABLES = ("lmp", "lmp_serial", "lmp_mpi")


def find_lammps(executable=None):
    """Path of the LAMMPS executable (``executable`` or the first of LAMMPS_EXECUTABLES on PATH), or None."""
    names = (executable,) if executable else LAMMPS_EXECUTABLES
    for name in names:
        path = shutil.which(name)
        if path:
            return path
    return None


class LammpsError(RuntimeError):
    """LAMMPS failed; the message carries the end of its log."""


@dataclass
class SceneRun:
    """What a scene run produced.

    Attributes
    ----------
    scene : Scene
    workdir : str
        Directory with the data file, input script, log and dumps.
    thermo : dict of arrays
        ``step``, ``time``, ``kinetic_energy`` (of the flowing particles) at every thermo line.
    snapshots : list of Snapshot
        Frames of every :class:`Frames` stage (with contacts and body force).
    trace : dict of arrays or None
        ``time``, ``positions`` (T, N, D), ``velocities`` (T, N, D) of a :class:`Trace` stage.
    wall_time : float
        Seconds LAMMPS ran.
    """

    scene: object
    workdir: str
    thermo: dict
    snapshots: list = field(default_factory=list)
    trace: dict = None
    wall_time: float = 0.0

    @property
    def input_script(self):
        with open(os.path.join(self.workdir, lmp_input.INPUT_FILE)) as f:
            return f.read()

    def write_snapshots(self, path, provenance=None, compression=None):
        """Write the frames to ``path`` in cgbound's HDF5 format (atomically; ``compression`` as
        :func:`cgbound.readers.write_snapshots` takes it); returns the count."""
        from ...readers.hdf5 import write_snapshots
        info = {"scene": self.scene.name, "effects": list(self.scene.effects), "engine": "LAMMPS",
                "input_script": self.input_script, "lammps_wall_time_s": self.wall_time}
        info.update(provenance or {})
        return write_snapshots(path, self.snapshots, provenance=info, compression=compression)


def _thermo(log_text):
    rows = []
    block = False
    for line in log_text.splitlines():
        words = line.split()
        if words[:3] == ["Step", "Time", "c_ke"]:
            block = True
            continue
        if block:
            # the block ends at the first line that is not three numbers (Loop time, a warning, a blank line)
            try:
                if len(words) < 3:
                    raise ValueError
                rows.append([float(w) for w in words[:3]])
            except ValueError:
                block = False
    rows = np.array(rows, float).reshape(-1, 3)
    if rows.size:
        # thermo repeats the last line of a run as the first of the next; keep one of each step
        _, keep = np.unique(rows[:, 0], return_index=True)
        rows = rows[np.sort(keep)]
    return {"step": rows[:, 0].astype(np.int64), "time": rows[:, 1], "kinetic_energy": rows[:, 2]}


def run_scene(scene, stages, workdir=None, executable=None, timeout=None, keep=True):
    """Write the scene's LAMMPS input, run ``lmp`` on it, and read back thermo, frames and trace.

    Parameters
    ----------
    scene : Scene
    stages : sequence of Settle, Run, Frames, Trace
    workdir : str, optional
        Where to run (created if needed). Default: a new temporary directory.
    executable : str, optional
        LAMMPS executable (default: ``lmp`` on PATH).
    timeout : float, optional
        Seconds before LAMMPS is stopped.
    """
    from ...readers.lammps import LammpsReader
    from .scene import Scene
    if not isinstance(scene, Scene):
        raise TypeError(f"scene: expected a cgbound.scenes.Scene, got {type(scene).__name__}")
    stages = list(stages)
    script = lmp_input.input_script(scene, stages)  # validates the stages before any work
    exe = find_lammps(executable)
    if exe is None:
        raise FileNotFoundError(f"executable: LAMMPS not found ({executable or ' / '.join(LAMMPS_EXECUTABLES)}; "
                                "apt-get install lammps provides lmp)")
    workdir = tempfile.mkdtemp(prefix=f"cgbound-{scene.name}-") if workdir is None else os.fspath(workdir)
    os.makedirs(workdir, exist_ok=True)
    for name in (lmp_input.FRAME_ATOMS, lmp_input.FRAME_PAIRS, lmp_input.TRACE_FILE, "log.lammps"):
        if os.path.exists(os.path.join(workdir, name)):
            os.remove(os.path.join(workdir, name))  # dumps are appended to: start clean
    with open(os.path.join(workdir, lmp_input.DATA_FILE), "w") as f:
        f.write(lmp_input.data_file(scene))
    with open(os.path.join(workdir, lmp_input.INPUT_FILE), "w") as f:
        f.write(script)
    start = time.perf_counter()
    proc = subprocess.run([exe, "-in", lmp_input.INPUT_FILE, "-log", "log.lammps", "-screen", "none"],
                          cwd=workdir, capture_output=True, text=True, timeout=timeout)
    wall = time.perf_counter() - start
    log_path = os.path.join(workdir, "log.lammps")
    log = open(log_path).read() if os.path.exists(log_path) else proc.stdout
    if proc.returncode != 0 or "ERROR" in log:
        tail = "\n".join((log + proc.stderr).strip().splitlines()[-15:])
        raise LammpsError(f"LAMMPS failed on scene {scene.name!r} (exit {proc.returncode}) in {workdir}:\n{tail}")
    result = SceneRun(scene=scene, workdir=workdir, thermo=_thermo(log), wall_time=wall)
    if any(isinstance(s, lmp_input.Frames) for s in stages):
        reader = LammpsReader(os.path.join(workdir, lmp_input.FRAME_ATOMS), os.path.join(workdir, lmp_input.FRAME_PAIRS),
                              pair_values=lmp_input.PAIR_VALUES, walls=[f"wall{k}" for k in range(len(scene.walls))],
                              fixed_types=[2] if np.any(scene.fixed) else [],
                              body_force=scene.gravity if scene.gravity is not None else None,
                              dimension=scene.dim, dt=scene.timestep)
        result.snapshots = list(reader)
        for snap in result.snapshots:
            if not np.allclose(snap.masses, scene.masses, rtol=1e-12, atol=0):
                raise LammpsError("masses: LAMMPS computed other particle masses than the scene's "
                                  "(data-file density convention differs in this LAMMPS version)")
    if any(isinstance(s, lmp_input.Trace) for s in stages):
        result.trace = _read_trace(scene, os.path.join(workdir, lmp_input.TRACE_FILE))
    return result


def _read_trace(scene, path):
    """Positions and velocities from the trace dump (id x y z vx vy vz, sorted by id)."""
    times, rows = [], []
    with open(path) as f:
        lines = f.read().splitlines()
    k = 0
    n = scene.n_particles
    while k < len(lines):
        if lines[k].startswith("ITEM: TIMESTEP"):
            times.append(int(lines[k + 1]) * scene.timestep)
            k += 2
        elif lines[k].startswith("ITEM: ATOMS"):
            block = np.array([line.split() for line in lines[k + 1:k + 1 + n]], float)
            rows.append(block)
            k += 1 + n
        else:
            k += 1
    data = np.array(rows)
    axes = [1, 2] if scene.dim == 2 else [1, 2, 3]
    return {"time": np.array(times), "positions": data[:, :, axes], "velocities": data[:, :, [a + 3 for a in axes]]}
