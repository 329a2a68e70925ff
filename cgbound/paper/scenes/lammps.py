"""Engine input for a :class:`~cgbound.paper.scenes.Scene`: a LAMMPS data file and input script.

The script contains exactly the effects of :attr:`Scene.effects` (no gravity fix without
gravity, no tangential history without a tangential spring, no rotation integration without
rotation, ...). Frames for coarse graining are dumped inside ``run 0`` so that per-contact and
per-particle forces come from one force evaluation (see :mod:`cgbound.readers.lammps`).

Axes: a 2D scene's axes (x, z) are LAMMPS's (x, y); LAMMPS's z is a thin periodic slab.
Atom types: 1 flowing, 2 fixed. Atom IDs are 1..N in scene order.
"""
from dataclasses import dataclass, replace

import numpy as np

from .scene import CylinderWall, Wall

#: file names used inside a scene's work directory
DATA_FILE = "scene.data"
INPUT_FILE = "in.scene"
FRAME_ATOMS = "frames.atoms.dump"
FRAME_PAIRS = "frames.pairs.dump"
TRACE_FILE = "trace.dump"
#: keywords of compute pair/local (the reader's "gran" layout)
PAIR_VALUES = ("dist", "fx", "fy", "fz", "p1", "p2", "p3", "p4")


@dataclass(frozen=True)
class Settle:
    """Run in chunks until the kinetic energy of the flowing particles is below ``tolerance``.

    Fails (LAMMPS stops with an error message) if that takes longer than ``max_time``.
    """

    tolerance: float = 1e-20
    chunk: float = 0.5
    max_time: float = 200.0


@dataclass(frozen=True)
class Run:
    """Run for ``duration`` time units, printing the kinetic energy every ``thermo_every`` time units."""

    duration: float
    thermo_every: float = 1.0


@dataclass(frozen=True)
class Frames:
    """``count`` snapshots with contacts, ``interval`` time units apart, the first one now."""

    count: int
    interval: float


@dataclass(frozen=True)
class MoveWall:
    """Move the flat wall ``walls[index]`` (a :class:`~cgbound.paper.scenes.Wall`) from the scene's
    position to ``position``: at once (``duration`` 0), or at constant speed over ``duration`` time units.

    Lowering a silo's bottom slowly under a column at rest lets the column slide down along the
    side wall, which mobilises the wall friction everywhere (the state Janssen's analysis assumes).
    """

    index: int
    position: float
    duration: float = 0.0


@dataclass(frozen=True)
class Trace:
    """Dump positions and velocities every ``every`` steps for ``duration`` time units (no contacts)."""

    duration: float
    every: int = 1


def _f(x):
    """A float as LAMMPS reads it, exactly (shortest round-trip repr)."""
    return repr(float(x))


def _steps(scene, duration, what):
    steps = duration / scene.timestep
    n = int(round(steps))
    if n < 0 or abs(n - steps) > 1e-6 * max(1.0, steps):
        raise ValueError(f"{what}: expected a non-negative multiple of the time step {scene.timestep:g}, got {duration!r}")
    return n


def _lammps_xyz(scene, values):
    """Scene coordinates -> LAMMPS (x, y, z)."""
    values = np.asarray(values, float)
    if scene.dim == 3:
        return values
    out = np.zeros(values.shape[:-1] + (3,))
    out[..., :2] = values
    return out


def data_file(scene):
    """Text of the LAMMPS data file (atom_style sphere: id type diameter density x y z)."""
    lo = _lammps_xyz(scene, scene.box.lower)
    hi = _lammps_xyz(scene, scene.box.upper)
    if scene.dim == 2:
        lo[2], hi[2] = -0.5, 0.5
    # LAMMPS computes mass = density * (pi/6) d^3 (also in 2D in the versions checked); the
    # runner compares the dumped masses with the scene's, so another convention cannot go unnoticed
    density = scene.masses / (np.pi / 6.0 * (2.0 * scene.radii) ** 3)
    xyz = _lammps_xyz(scene, scene.positions)
    lines = [f"cgbound scene {scene.name}", "", f"{scene.n_particles} atoms", "2 atom types", ""]
    for a, name in enumerate("xyz"):
        lines.append(f"{_f(lo[a])} {_f(hi[a])} {name}lo {name}hi")
    lines += ["", "Atoms # sphere", ""]
    for k in range(scene.n_particles):
        lines.append(f"{k + 1} {2 if scene.fixed[k] else 1} {_f(2.0 * scene.radii[k])} {_f(density[k])} "
                     f"{_f(xyz[k, 0])} {_f(xyz[k, 1])} {_f(xyz[k, 2])}")
    if scene.velocities is not None and np.any(scene.velocities != 0):
        v = _lammps_xyz(scene, scene.velocities)
        lines += ["", "Velocities", ""]
        lines += [f"{k + 1} {_f(v[k, 0])} {_f(v[k, 1])} {_f(v[k, 2])} 0 0 0" for k in range(scene.n_particles)]
    return "\n".join(lines) + "\n"


def _contact_model(c):
    """LAMMPS's hooke model words and coefficients, shared by the pair style and the walls."""
    if c.tangential:
        # dampflag 1: tangential damping on (gamma_t > 0) or off
        return (f"hooke/history {_f(c.kn)} {_f(c.kt)} {_f(c.gamma_n)} {_f(c.gamma_t)} {_f(c.friction)} "
                f"{1 if c.gamma_t > 0 else 0}")
    # without tangential damping or friction: normal force only
    return f"hooke {_f(c.kn)} NULL {_f(c.gamma_n)} 0.0 0.0 0"


def _wall_fix(scene, k, wall):
    if isinstance(wall, CylinderWall):
        # an unbounded cylinder region (INF ends, meaning -inf and +inf: no caps); the particles are on its inside
        c1, c2 = wall.center
        return [f"region          wall{k}region cylinder {wall.axis} {_f(c1)} {_f(c2)} {_f(wall.radius)} INF INF "
                "side in units box",
                f"fix             wall{k} flow wall/gran/region {_contact_model(scene.contacts)} region wall{k}region "
                "contacts"]
    axis = "y" if scene.dim == 2 and wall.axis == "z" else wall.axis  # 2D: cgbound's z is LAMMPS's y
    lo, hi = (_f(wall.position), "NULL") if wall.side == "above" else ("NULL", _f(wall.position))
    return [f"fix             wall{k} flow wall/gran {_contact_model(scene.contacts)} {axis}plane {lo} {hi} contacts"]


def input_script(scene, stages):
    """Text of the LAMMPS input script running ``stages`` (Settle, Run, Frames, Trace, MoveWall) in order."""
    c = scene.contacts
    fixed = bool(np.any(scene.fixed))
    periodic = ["p" if p else ("m" if scene.dim == 3 else "f") for p in scene.box.periodic]
    boundary = " ".join(periodic + (["p"] if scene.dim == 2 else []))
    neighbour_skin = 0.1 * float(2.0 * scene.radii.min())
    out = [f"# cgbound scene {scene.name!r}",
           f"# effects: {', '.join(scene.effects)}",
           "units           lj",
           "atom_style      sphere",
           f"dimension       {scene.dim}",
           f"boundary        {boundary}",
           # contacts carry velocities across processors and periodic images
           "comm_modify     vel yes",
           f"read_data       {DATA_FILE}",
           "group           flow type 1"]
    if fixed:
        out.append("group           fixed type 2")
    out += [f"pair_style      gran/{_contact_model(c)}", "pair_coeff      * *",
            f"neighbor        {_f(neighbour_skin)} bin",
            "neigh_modify    delay 0" + (" exclude type 2 2" if fixed else ""),
            f"timestep        {_f(scene.timestep)}",
            f"fix             integrate flow {'nve/sphere' if scene.rotation else 'nve'}"]
    if fixed:
        # fixed particles are not integrated; freeze also makes them count as infinitely heavy in contacts
        out.append("fix             frozen fixed freeze")
    if "gravity" in scene.effects:
        g = _lammps_xyz(scene, scene.gravity)
        norm = float(np.linalg.norm(g))
        u = g / norm
        out.append(f"fix             gravity flow gravity {_f(norm)} vector {_f(u[0])} {_f(u[1])} {_f(u[2])}")
    if scene.damping is not None:
        out.append(f"fix             damping flow viscous {_f(scene.damping)}")
    for k, wall in enumerate(scene.walls):
        out += _wall_fix(scene, k, wall)
    if scene.dim == 2:
        out.append("fix             plane all enforce2d")
    out += ["compute         ke flow ke",
            "thermo_style    custom step time c_ke",
            "thermo_modify   norm no format float %.17g",
            f"compute         pl all pair/local {' '.join(PAIR_VALUES)}",
            "compute         pp all property/local patom1 patom2"]
    for n, stage in enumerate(stages):
        out.append(f"# stage {n}: {stage!r}")
        out += _stage(scene, n, stage)
    return "\n".join(out) + "\n"


def _wall_columns(scene):
    return "".join(f" f_wall{k}[*]" for k in range(len(scene.walls)))


def _stage(scene, n, stage):
    if isinstance(stage, Run):
        every = max(1, _steps(scene, stage.thermo_every, "thermo_every"))
        return [f"thermo          {every}", f"run             {_steps(scene, stage.duration, 'duration')}"]
    if isinstance(stage, Settle):
        chunk = _steps(scene, stage.chunk, "chunk")
        chunks = int(np.ceil(stage.max_time / stage.chunk))
        if chunk < 1:
            raise ValueError("chunk: expected at least one time step")
        return [f"thermo          {chunk}",
                f"variable        settle{n} loop {chunks}",
                f"label           settle{n}",
                f"run             {chunk}",
                f"if              \"$(c_ke) < {_f(stage.tolerance)}\" then \"jump SELF settled{n}\"",
                f"next            settle{n}",
                f"jump            SELF settle{n}",
                f"print           \"CGBOUND-ERROR: not settled after {_f(stage.max_time)} time units\"",
                "quit            3",
                f"label           settled{n}",
                "print           \"CGBOUND-SETTLED $(time)\""]
    if isinstance(stage, Frames):
        if not (isinstance(stage.count, (int, np.integer)) and stage.count >= 1):
            raise ValueError(f"count: expected a positive integer, got {stage.count!r}")
        interval = _steps(scene, stage.interval, "interval")
        return [f"variable        frame{n} loop {int(stage.count)}",
                f"label           frame{n}",
                f"dump            fa all custom 1 {FRAME_ATOMS} id type x y z vx vy vz fx fy fz radius mass"
                + _wall_columns(scene),
                f"dump            fp all local 1 {FRAME_PAIRS} index c_pp[*] c_pl[*]",
                "dump_modify     fa format float %.17g append yes sort id",
                "dump_modify     fp format float %.17g append yes",
                "run             0",
                "undump          fa",
                "undump          fp",
                f"if              \"${{frame{n}}} < {int(stage.count)}\" then \"run {interval}\"",
                f"next            frame{n}",
                f"jump            SELF frame{n}"]
    if isinstance(stage, Trace):
        return [f"dump            tr all custom {int(stage.every)} {TRACE_FILE} id x y z vx vy vz",
                "dump_modify     tr format float %.17g sort id",
                f"run             {_steps(scene, stage.duration, 'duration')}",
                "undump          tr"]
    if isinstance(stage, MoveWall):
        k = stage.index
        if not (isinstance(k, (int, np.integer)) and 0 <= k < len(scene.walls) and isinstance(scene.walls[k], Wall)):
            raise ValueError(f"index: expected the index of a flat Wall of the scene, got {k!r}")
        if not np.isfinite(stage.position):
            raise ValueError(f"position: expected a finite number, got {stage.position!r}")
        wall = scene.walls[k]
        moved = replace(wall, position=float(stage.position))
        out = [f"unfix           wall{k}"]
        steps = _steps(scene, stage.duration, "duration")
        if steps:
            # a plane region moving at constant speed (LAMMPS gives the wall/gran/region contacts its velocity)
            axis = "xyz".index("y" if scene.dim == 2 and wall.axis == "z" else wall.axis)
            point, normal = [0.0] * 3, [0.0] * 3
            point[axis], normal[axis] = wall.position, (1.0 if wall.side == "above" else -1.0)
            shift = ["NULL"] * 3
            shift[axis] = f"v_wall{k}shift{n}"
            out += [f"variable        wall{k}shift{n} equal \"ramp(0.0,{_f(stage.position - wall.position)})\"",
                    f"region          wall{k}moving{n} plane {' '.join(_f(v) for v in point + normal)} side in "
                    f"move {' '.join(shift)} units box",
                    f"fix             wall{k} flow wall/gran/region {_contact_model(scene.contacts)} "
                    f"region wall{k}moving{n} contacts",
                    f"run             {steps}",
                    f"unfix           wall{k}"]
        # the same fix ID, so the frames' wall columns keep their names
        return out + _wall_fix(scene, k, moved)
    raise TypeError(f"stages: expected Settle, Run, Frames, Trace or MoveWall, got {type(stage).__name__}")
