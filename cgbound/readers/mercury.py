"""Read MercuryDPM output (``.data`` + ``.fstat``, optionally ``.restart``) as a lazy sequence of
:class:`cgbound.Snapshot`.

Sources
-------
The layouts below were taken from the MercuryDPM source (BSD licence; the copy read was the
2013-2020 "MercuryDPM Developers Team" kernel as mirrored on GitHub, ``Kernel/DPMBase.cc``,
``Kernel/Interactions/BaseInteraction.cc``, ``Kernel/Particles/BaseParticle.cc``,
``Kernel/Species/ParticleSpecies.cc``):

* ``DPMBase::outputXBallsData`` / ``DPMBase::readNextDataFile`` (``.data``, XBalls "format 14"
  in 3D and "format 8" in 2D);
* ``DPMBase::writeFstatHeader`` and ``BaseInteraction::writeToFStat`` (``.fstat``), checked
  against ``DPMBase::readNextFStatFile`` and ``BaseInteraction::setFStatData``, which read the
  file back;
* ``BaseParticle::write`` (``... radius R invMass m``, ``invMass 0`` = fixed) and
  ``ParticleSpecies::write`` (``<Name> id K density rho ...``) for the ``.restart`` keys.

No MercuryDPM binary was run to produce the test files: they are written by hand following
these sources (MercuryDPM is not installable where this was written). See "Unverified" below.

``.data`` (one block per saved time step)
-----------------------------------------
3D header ``N time xmin ymin zmin xmax ymax zmax`` then N lines
``x y z vx vy vz radius ax ay az wx wy wz species`` (a = Euler angles of the orientation,
w = angular velocity). 2D header ``N time xmin ymin xmax ymax`` then N lines
``x y vx vy radius angle omega species``. Extra trailing columns (some drivers append the
particle ID) are ignored. The dimension is taken from the header length unless ``dim=`` is given.

**2D axes.** MercuryDPM's 2D runs use x and y; cgbound's 2D axes are called (x, z). The
MercuryDPM x, y columns become cgbound's first and second axis unchanged (so MercuryDPM's y,
usually the gravity direction in 2D, is cgbound's z). ``body_force`` is given in cgbound axes
(2 values) or as the 3 MercuryDPM components (the third must be 0).

``.fstat`` (one block per saved time step)
------------------------------------------
Three header lines::

    # time marker             (marker 1: column 4-6 is the contact point; 0: older files, the "centre")
    # xmin ymin zmin xmax ymax zmax
    # rmin rmax 0 0 0 0

then one line per interaction side (always 3-vectors, also in 2D runs, z = 0)::

    time i j cx cy cz delta deltat fn ft nx ny nz tx ty tz

with ``j >= 0`` a particle index and ``j = -1 - wallIndex`` a wall. ``writeToFStat`` writes a
pair contact twice, once from each non-fixed side (the second line has i and j swapped and n, t
negated; c, delta, fn, ft are the same), a contact with a fixed particle once (from the flowing
side), and a wall contact once. In a pair line n points from j to i (``BaseInteraction::
setNormal``: "in direction from I to P"), and the force ON i is ``fn n + ft t``. For walls,
``writeToFStat`` writes ``-normal`` and ``-tangential`` (marked in the source as "an old bug"),
so the force on the particle is ``-(fn n + ft t)``. This reader does not rely on that flag: for
every line it takes ``s = sign(n . (x_i - c))`` (the interaction normal points from the partner
towards particle i, and the contact point lies on that line) and the force on i as
``s (fn n + ft t)``. For pairs s = +1 always; for walls it is -1 with the sources above and +1
should MercuryDPM ever fix the flip.

Double listings are merged: the two lines of a pair must carry opposite forces and the same
contact point (within ``rtol`` of the frame's largest force / particle diameter); otherwise a
ValueError names the file and both line numbers. A pair listed more than twice, or twice from
the same side, is an error too, and so is a pair of two flowing particles listed once (a lost line:
MercuryDPM writes those from both sides). The kept orientation is i < j. Walls become ``j = -1``
(:attr:`MercuryFrame.wall_index` keeps which wall). Contact points of ``marker 0`` files (the
"centre" of older versions: the midpoint of the overlap-corrected centre line for pairs, the
wall-surface point for walls) are used as contact points unchanged.

Masses, fixed particles, periodicity
------------------------------------
The ``.data`` file has no masses. ``mass = density x volume``: 4/3 pi R^3 for spheres, pi R^2
(per unit thickness) for discs (``particle_dim``; default: 3 in 3D runs, 2 in 2D runs, or the
``particleDimensions`` key of the ``.restart`` when present), with the density of the species
from ``density=`` (a number, or {species: density}) or else from the ``.restart`` species lines
(``... id K density rho``). Fixed particles: ``fixed=`` (indices, an N-bool mask, or a callable
``fixed(radius, species) -> bool mask``), else from the ``.restart`` particle lines
(``invMass 0``) in the order of its lines: a frame's row k is the restart's k-th particle (MercuryDPM appends inserted
particles, so a frame may hold fewer particles than the restart, never more; ids are not
row numbers, since insertion attempts use ids too), and every fixed
particle must sit in the frame where the restart has it (fixed particles do not move), else the
frame is refused. Template particles inside boundary lines (``ChuteInsertionBoundary``) are not
particles; a ``Particles N`` section with fewer lines is a truncated file and an error. Periodic axes: ``periodic=`` (per cgbound axis), else from
``PeriodicBoundary ... normal nx ny nz`` lines of the ``.restart``. Body force: ``body_force=``, else the
``.restart``'s ``gravity`` (``DPMBase::write``: ``systemDimensions D particleDimensions P gravity gx gy gz``; a
chute's is tilted by its angle, e.g. ``(sin 24, 0, -cos 24)``); when both are known they must agree, unless the
restart's is 0 (weight applied by the driver's code: the given one is used, with a warning) or
``body_force_override=True``. A 2D run whose restart gravity has a z component needs ``body_force=``.

Reading and structure checks
----------------------------
Frames are found by one scan of each file (the C text layer's line finder) and parsed lazily, one C pass
per frame (``species``, ``i``, ``j`` read as exact int64); the per-line work on a ``.fstat`` frame (the lines'
times, the partners' indices, the force on i and its orientation, the pairing of the two sides, the walls) is a
second C pass (``csrc/cg_fstat.h``; its NumPy twin is ``oracle_fstat_contacts`` in the tests); gzipped files are decompressed as a zlib stream
(the scan holds one decompressed copy of the file at a time; a frame read streams from the start). Refused,
with the file, the frame's time and the line: a ``.data`` frame with fewer particle lines than its header
declares, a particle line with a value more or less than the frame's first (the columns would shift), a
``.fstat`` block of ``#`` lines that is not 3 per frame (a header line lost, or a blank line inserted), an
interaction line whose time is not its frame's, an interaction line whose contact point lies outside the sphere
(radius plus |overlap|, 1 % and the file's rounding of slack) of its particle or partner particle in the ``.data``
frame (an ``.fstat`` of another run or frame, or a damaged index: a contact with a fixed particle or a wall is
listed once, so no pairing check would see it), a last ``.fstat`` frame cut off after its header while
earlier frames have contacts, a ``.data`` or ``.fstat`` whose last line has no newline (cut while written or
copied: a cut inside the last number keeps the line's length; a complete file written without its final newline
needs one added), a ``.restart`` without a complete ``Particles N``
section, a flowing particle whose radius is not positive, empty or
whitespace-only files, nan/inf, non-numbers and bytes that are not text.

Unverified / not supported
--------------------------
* No file produced by a MercuryDPM run was available: the layouts follow the source only.
  Older MercuryDPM versions (``marker 0``) may differ in more than the contact-point column.
* Interactions with periodic ghost particles: ``writeToFStat`` writes them once, with j the
  ghost's index (>= the number of particles in ``.data``). Those lines raise a ValueError
  (the ghost's original particle is not recorded in the files).
* Restart parsing is key-based (``density``, ``invMass``, ``particleDimensions``, ``normal`` of
  ``PeriodicBoundary``); other restart content (walls, insertion boundaries) is ignored.
* Frames are matched by time: a ``.data`` frame without an ``.fstat`` frame of the same time
  (within 1e-9 relative) raises; unmatched ``.fstat`` frames are ignored. Frames of one time written
  more than once (a run restarted and appended) pair in file order, with a warning (a time average counts
  each copy).
"""
from dataclasses import dataclass
import math
import numbers
import os
import warnings

import numpy as np

from .. import _engine
from .._validate import finite_number, flag, index_array, integer
from ..box import Box
from ..snapshot import Contacts, Snapshot
from .checks import row_squares, warn_repeated_frames
from ._mercury_files import LINE_TIME_RTOL, fstat_rows, read_particles, read_restart, scan_data, scan_fstat
from ._mercury_write import write_mercury
from .files import CompanionFileWarning, companion
from ._sequence import FrameReader, file_name
from ._text import hold_spare

__all__ = ["MercuryReader", "MercuryFrame", "write_mercury"]

# the problems cg_fstat_contacts reports (csrc/cg_fstat.h, cg_fstat_problem)
_FSTAT_TIME, _FSTAT_PARTICLE, _FSTAT_GHOST, _FSTAT_SELF, _FSTAT_FLAT, _FSTAT_REPEATED, _FSTAT_INCONSISTENT, \
    _FSTAT_ONCE = range(1, 9)
# the Snapshot arrays taken as parsed from the .data file (Snapshot.from_reader)
_PARSED = ("positions", "velocities", "radii", "angular_velocities")


# ----------------------------------------------------------------------------------------------

@dataclass
class MercuryFrame:
    """One frame: ``snapshot`` plus ``wall_index`` ((M,) MercuryDPM wall index, -1 for pairs),
    ``overlap`` ((M,) delta), ``data_line`` and ``fstat_line`` (line numbers of the frame headers)."""

    snapshot: Snapshot
    wall_index: np.ndarray
    overlap: np.ndarray
    data_line: int
    fstat_line: int


class MercuryReader(FrameReader):
    """Lazy sequence of :class:`cgbound.Snapshot` from MercuryDPM output (see the module docstring);
    :meth:`frame` gives a :class:`MercuryFrame`.

    Parameters
    ----------
    data_path : path
        The ``.data`` file (XBalls format 14 in 3D, 8 in 2D).
    fstat_path : path or False, optional
        The ``.fstat`` file; without it frames have no contacts. When it is not given and
        ``name.fstat`` lies beside ``name.data``, a :class:`CompanionFileWarning` says so
        (``False``: read the particles alone, without the warning).
    restart_path : path or False, optional
        The ``.restart`` file: species densities, fixed particles, periodic axes. When it is not
        given, ``name.restart`` lies beside ``name.data`` and ``fixed=`` or ``periodic=`` is not
        given either, a :class:`CompanionFileWarning` says so (``False``: without the warning).
    fixed : indices, (N,) bools, or callable(radius, species) -> (N,) bools, optional
    body_force : (D,) body force per unit mass on flowing particles, cgbound axes
        (in 2D also the 3 MercuryDPM components, third 0). Default: the ``.restart``'s gravity; when both are
        known they must agree (to 1e-4 of the larger), unless the restart's is 0 (a warning; the given one is used)
        or, in 2D, has a third component (a warning; the given one is used).
    dim : 2 or 3, optional
        Checked against the ``.data`` headers (default: from them).
    density : number or {species: density}, optional
        Overrides the restart's species densities.
    particle_dim : 2 or 3, optional
        Mass = density x (pi R^2 if 2, 4/3 pi R^3 if 3).
    periodic : sequence of D bools, optional
        Periodic axes (default: from the restart's PeriodicBoundary lines, else none).
    rtol : float
        Tolerance for the two lines of a pair (relative to the frame's largest force, and to
        the largest particle diameter for the contact point).
    body_force_override : bool
        Use ``body_force`` even where it contradicts the ``.restart``'s nonzero gravity (a body force changed
        during the run, or applied by the driver's own code). Default False: refused.
    """

    def __init__(self, data_path, fstat_path=None, *, restart_path=None, fixed=None, body_force=None, dim=None,
                 density=None, particle_dim=None, periodic=None, rtol=1e-9, units=None, body_force_override=False):
        self.units = units
        if dim is not None and dim not in (2, 3):
            raise ValueError(f"dim: expected 2 or 3, got {dim!r}")
        self.data_path = os.path.abspath(os.fspath(data_path))
        self.fstat_path = self._optional_path(fstat_path, "fstat_path")
        self.restart_path = self._optional_path(restart_path, "restart_path")
        if fstat_path is None:
            self._warn_companion(".fstat", "fstat_path", "the frames have no contacts (no contact stress, no "
                                 "interaction force density)")
        if restart_path is None and (fixed is None or periodic is None):
            lost = (["no particle is fixed (a base's particles count as flowing)"] if fixed is None else []) + (
                ["no axis is periodic"] if periodic is None else [])
            self._warn_companion(".restart", "restart_path", " and ".join(lost))
        data_frames = scan_data(self.data_path, dim)
        hold_spare(self)   # frames' text in one reused buffer while this reader lives
        dims = {f[4] for f in data_frames}
        if len(dims) > 1:
            raise ValueError(f"{self.data_path}: mixes 2D and 3D headers")
        self.dim = dim if dim is not None else (dims.pop() if dims else 3)
        restart = read_restart(self.restart_path) if self.restart_path else None
        self._restart = None if restart is None else {"inv_mass": restart["inv_mass"],
                                                      "positions": restart["positions"]}
        self.density = self._densities(density, restart)
        pdim = particle_dim if particle_dim is not None else (restart or {}).get("particle_dim")
        self.particle_dim = integer(pdim, "particle_dim") if pdim is not None else self.dim
        if self.particle_dim not in (2, 3):
            raise ValueError(f"particle_dim: expected 2 or 3, got {pdim!r}")
        self.fixed = fixed if callable(fixed) or fixed is None else np.asarray(fixed)
        self.body_force = self._body_force(body_force, restart, flag(body_force_override, "body_force_override"))
        self.periodic = self._periodic(periodic, restart)
        self.rtol = finite_number(rtol, "rtol")
        if self.rtol < 0:
            raise ValueError(f"rtol: expected a non-negative number, got {rtol!r}")
        self._frames = self._match(data_frames)
        self._warn_repeated_times(data_frames)
        self._cache = None

    def _warn_repeated_times(self, data_frames):
        """A time written twice (a run restarted and appended to its files writes the restart's frames again) is
        read twice: a time average counts it twice. Allowed, but not silently."""
        warn_repeated_frames(self.data_path, ((f[3], f[1]) for f in data_frames), lambda t: f"the frame at t = {t:g}",
                             "lines", "as by a run restarted and appended to its files", "time", "time")

    # ------------------------------------------------------------------------------------------
    @staticmethod
    def _optional_path(value, name):
        """A companion file's absolute path; None for None or False (not given, or declined)."""
        if value is None or value is False:
            return None
        if not isinstance(value, (str, bytes, os.PathLike)):
            raise TypeError(f"{name}: expected a path, None or False, got {value!r}")
        return os.path.abspath(os.fspath(value))

    def _warn_companion(self, suffix, keyword, consequence):
        """Say so when ``name<suffix>`` lies beside ``name.data`` but ``keyword=`` was not given: reading
        without it is allowed, but not silently."""
        found = companion(self.data_path, ".data", suffix)
        if found is not None:
            warnings.warn(f"{found} lies beside {self.data_path} but {keyword}= was not given, so {consequence}; "
                          f"pass {keyword}={found!r} to use it, or {keyword}=False to read without it",
                          CompanionFileWarning, stacklevel=3)

    #: how far a given body_force may differ from the .restart's gravity (relative to its magnitude): the restart
    #: writes 15 significant digits, a user types a few (0.40674, 0, -0.91355)
    GRAVITY_RTOL = 1e-4

    def _body_force(self, body_force, restart, override):
        """``body_force=``, checked against the gravity the run used (the .restart's), else that gravity: a chute's
        is tilted by its angle (ChuteDemo: (sin 24, 0, -cos 24)), so a guessed (0, 0, -1) would unbalance every
        momentum balance silently. A restart gravity of 0 (the weight applied by the driver's own code) gives way to
        a given one, with a warning; a contradicting nonzero one only to ``body_force_override=True``."""
        given = self._check_body_force(body_force, self.dim, "MercuryDPM")
        g = None if restart is None else restart.get("gravity")
        if override and given is None:
            raise ValueError("body_force_override: True needs body_force= (--gravity), the body force to use")
        if g is None or (override and given is not None):
            return given
        if self.dim == 2 and g[2] != 0:
            if given is not None:
                # the plane's two components, given, say what the 3-component restart cannot
                warnings.warn(f"{self.restart_path}: the 2D run's gravity {g.tolist()} has a third component; the "
                              f"given body force {given.tolist()} is used", stacklevel=3)
                return given
            raise ValueError(f"{self.restart_path}: a 2D run with gravity {g.tolist()} (its third component is not "
                             f"0, outside the plane): pass body_force= (--gravity) with the plane's two components "
                             f"(MercuryDPM x, y)")
        if self.dim == 2:
            g = g[:2]
        if given is None:
            return g if np.any(g) else None
        if not np.any(g):
            warnings.warn(f"{self.restart_path}: the run's gravity is 0; the given body force {given.tolist()} is "
                          f"used (the weight applied by the driver's own code)", stacklevel=3)
            return given
        scale = max(float(np.max(np.abs(g))), float(np.max(np.abs(given))))
        if float(np.max(np.abs(given - g))) > self.GRAVITY_RTOL * scale:
            raise ValueError(f"body_force: {given.tolist()} is not the gravity the run used, {g.tolist()} (the "
                             f"'gravity' of {self.restart_path}; a chute's gravity is tilted by its angle); leave it "
                             f"out to use the restart's, or, if the run's body force really differs from its stored "
                             f"gravity (changed during the run, custom forcing), pass body_force_override=True "
                             f"(--gravity-override)")
        return g

    def _densities(self, density, restart):
        if density is None:
            dens = dict(restart["density"]) if restart else {}
            return dens or None
        if isinstance(density, dict):
            return {int(k): float(v) for k, v in density.items()}
        if isinstance(density, numbers.Real) and not isinstance(density, bool):
            return float(density)
        raise ValueError(f"density: expected a number or a dict species -> density, got {density!r}")

    def _periodic(self, periodic, restart):
        if periodic is not None:
            p = tuple(bool(x) for x in np.broadcast_to(np.asarray(periodic, bool), (self.dim,)))
            return p
        flags = [False] * self.dim
        for n in (restart or {}).get("normals", []):
            a = int(np.argmax(np.abs(n)))
            if self.dim == 2 and a == 2:
                continue
            flags[a] = True
        return tuple(flags)

    def _match(self, data_frames):
        """One locator per .data frame: ((header line, time, header values), n, particle lines' byte range,
        the .fstat frame's (time, byte range of its lines, first line, header line) or None)."""
        particles = [((d[1], d[3], d[5]), d[2], d[6], d[7]) for d in data_frames]
        if self.fstat_path is None:
            return [(*p, None) for p in particles]
        fst = scan_fstat(self.fstat_path)
        times = np.array([f[2] for f in fst])
        used = np.zeros(len(fst), bool)
        out, missing = [], []
        for p, (_, _, _, t, *_) in zip(particles, data_frames):
            # the first .fstat frame of this time not taken by an earlier .data frame: frames written again at the
            # same time (a run restarted and appended) pair in file order, not all with the first of them
            same = np.flatnonzero((np.abs(times - t) <= 1e-9 * max(1.0, abs(t))) & ~used)
            if same.size:
                k = int(same[0])
                used[k] = True
                f = fst[k]
                out.append((*p, (f[2], f[4], f[5], f[6], f[1])))
                continue
            missing.append(t)
        if missing:
            raise ValueError(f"{self.fstat_path}: no .fstat frame for time(s) {missing[:10]} of {self.data_path}")
        return out

    @property
    def frame_times(self):
        """The frames' times as their headers give them (no frame is read)."""
        return [header[1] for header, *_ in self._frames]

    def _describe(self):
        return [file_name(self.data_path), file_name(self.fstat_path)], [f"{self.dim}D"]

    # ------------------------------------------------------------------------------------------
    # one frame: particles, fixed, masses, contacts

    def _build(self, header, n, rows_start, rows_stop, fstat):
        time, lower, upper, table, species = read_particles(self.data_path, header, n, self.dim, rows_start,
                                                            rows_stop)
        data_line = header[0]
        pos, vel, radii, species = self._particle_columns(table, species, data_line)
        box = Box(np.minimum(lower, upper), np.maximum(lower, upper), self.periodic)
        fixed = self._fixed(radii, species, n, pos, time)
        self._check_radii(radii, fixed, data_line, time)
        masses = self._masses(radii, species, fixed)
        if fstat is not None:
            contacts, wall_index, overlap = self._contacts(fstat, pos, radii, box, fixed)
        else:
            contacts, wall_index, overlap = Contacts.empty(self.dim), np.zeros(0, np.int64), np.zeros(0)
        # the .data angular velocities (wx wy wz; in 2D omega about MercuryDPM's z, the normal of cgbound's
        # (x, z) plane that makes it right-handed, docs/theory.md, "Rotation and couple stress")
        omega = table[:, 10:13] if self.dim == 3 else table[:, 6]
        # the internal path: the parsed columns were refused nan/inf by the parser and the contacts were checked
        # by the C pass (indices, one listing per pair); masses and forces, computed here, are still checked
        snap = Snapshot.from_reader(pos, velocities=vel, masses=masses, box=box, contacts=contacts, fixed=fixed,
                                    species=species, body_force=self.body_force, radii=radii, time=time,
                                    angular_velocities=omega, parsed=_PARSED, contacts_checked=True)
        return MercuryFrame(snap, wall_index, overlap, data_line, None if fstat is None else fstat[4])

    def _particle_columns(self, table, species, data_line):
        """Positions, velocities and radii from a .data particle table, and the species (integers)."""
        if self.dim == 3:
            pos, vel, radii = table[:, 0:3], table[:, 3:6], table[:, 6]
        else:
            pos, vel, radii = table[:, 0:2], table[:, 2:4], table[:, 4]
        if np.any(species < 0):
            raise ValueError(f"{self.data_path}: frame at line {data_line}: the species column holds negative "
                             f"values")
        return pos, vel, radii, species

    def _fixed(self, radii, species, n, positions, time):
        f = self.fixed
        if f is not None:
            out = self._fixed_given(f, radii, species, n, time)
            if not out.any():
                raise ValueError(f"fixed: selects no particle of the frame at t = {time:g} of {self.data_path} "
                                 f"({n} particles); check the predicate or the indices")
            return out
        if self._restart is None:
            return np.zeros(n, bool)
        return self._fixed_from_restart(n, positions, time)

    @staticmethod
    def _fixed_given(f, radii, species, n, time=0.0):
        """The fixed flags of ``fixed=``: a callable of (radius, species), N bools, or indices."""
        if callable(f):
            out = np.asarray(f(radii, species), dtype=bool)
            if out.shape != (n,):
                raise ValueError(f"fixed: the callable returned shape {out.shape}, expected ({n},)")
            return out
        if f.dtype == bool:
            if f.shape != (n,):
                raise ValueError(f"fixed: expected {n} bools, got shape {f.shape}")
            return f.copy()
        out = np.zeros(n, bool)
        idx = index_array(f.ravel(), "fixed")
        outside = idx[(idx < 0) | (idx >= n)]
        if outside.size:   # a ValueError, so that the command line names --fixed-ids
            raise ValueError(f"fixed: particle indices must lie in [0, {n}) (the frame at t = {time:g} has {n} "
                             f"particles), got {outside[:5].tolist()}; indices are the .data rows, from 0")
        out[idx] = True
        return out

    def _fixed_from_restart(self, n, positions, time):
        """The restart's fixed particles (invMass 0) in the order of its particle lines, which is the
        order of the .data rows: MercuryDPM appends inserted particles, so a frame with fewer particles
        than the restart holds its first ones. Fixed particles do not move, so each must sit where the
        restart has it."""
        inv, where = self._restart["inv_mass"], self._restart["positions"][:, :self.dim]
        if n > inv.size:
            raise ValueError(f"{self.restart_path}: holds {inv.size} particles but the frame at t = {time:g} of "
                             f"{self.data_path} has {n}; use the .restart written at the end of the run (particles "
                             f"are only appended), or pass fixed=")
        fixed = inv[:n] == 0
        idx = np.flatnonzero(fixed)
        if idx.size:
            scale = max(1.0, float(np.max(np.abs(where[idx]))))
            moved = np.max(np.abs(positions[idx] - where[idx]), axis=1) > 1e-8 * scale
            if np.any(moved):
                k = int(idx[np.flatnonzero(moved)[0]])
                raise ValueError(f"{self.data_path}: particle {k} is fixed in {self.restart_path} at "
                                 f"{where[k].tolist()} but sits at {positions[k].tolist()} in the frame at "
                                 f"t = {time:g}: the restart's particles are not this frame's rows (particles "
                                 f"deleted or reordered?); pass fixed= instead")
        return fixed


    def _check_radii(self, radii, fixed, data_line, time):
        """A flowing particle's mass is density x volume: a radius that is not positive is a damaged line (or a
        column shifted by a driver's own output), refused here by its line rather than as a mass."""
        bad = np.flatnonzero(~fixed & ~(radii > 0))
        if bad.size:
            k = int(bad[0])
            raise ValueError(f"{self.data_path}:{data_line + 1 + k}: particle {k} of the frame at t = {time:g} has "
                             f"radius {radii[k]:g}; a flowing particle needs a positive radius (its mass is density x "
                             f"volume): a damaged line, or a .data file of another layout")

    def _masses(self, radii, species, fixed):
        dens = self.density
        if dens is None:
            raise ValueError("density: the .data file has no masses; pass restart_path= (species densities) "
                             "or density= (a number or {species: density})")
        if isinstance(dens, float):
            rho = np.full(radii.shape, dens)
        else:
            missing = sorted(set(species[~fixed].tolist()) - set(dens))
            if missing:
                raise ValueError(f"density: no density for species {missing} (known: {sorted(dens)})")
            rho = np.array([dens.get(int(s), 1.0) for s in species])
        vol = (4.0 / 3.0) * math.pi * radii ** 3 if self.particle_dim == 3 else math.pi * radii ** 2
        m = rho * vol
        return np.where(fixed & ~(m > 0), 1.0, m)

    def _contacts(self, fstat, pos, radii, box, fixed):
        """The contacts of a .fstat frame: (Contacts, wall index, overlap). The per-line work (times, partners,
        the force on i and its orientation, the pairing, the walls) is one C pass, csrc/cg_fstat.h."""
        time = fstat[0]
        with fstat_rows(self.fstat_path, *fstat[:4]) as (rows, ints, line_of):   # (line_of: inside the block)
            if rows is None:
                return Contacts.empty(self.dim), np.zeros(0, np.int64), np.zeros(0)
            problem, detail, found = _engine.fstat_contacts(
                rows, ints, time, LINE_TIME_RTOL * max(1.0, abs(time)), pos, radii, fixed, box.periodic,
                [float(x) for x in box.lengths], self.rtol)
            if problem not in (0, _FSTAT_TIME, _FSTAT_PARTICLE, _FSTAT_GHOST):
                # every index is a particle's: a line whose point is not at its particles explains a pairing that
                # fails (lines of another run) better than the pairing's own message
                self._check_reach(rows, ints, line_of, time, pos, radii, box)
            if problem:
                raise self._fstat_problem(problem, detail, rows, ints, line_of, time, pos.shape[0])
            i, j, wall_index, force, point, overlap = found
            if not self._reach_holds(i, j, point, overlap, pos, radii, box):
                self._check_reach(rows, ints, line_of, time, pos, radii, box)   # (names the line)
        return Contacts.from_reader(i, j, force, point, parsed=("contacts.point",)), wall_index, overlap

    #: how far a contact point may lie outside a particle's sphere (r + abs(delta), delta the overlap: a cohesive
    #: contact's delta is negative) before the line is refused: a fraction of the reach, plus a fraction of the
    #: box's coordinates for the .fstat's rounding (10 significant digits; 6 in files of older versions)
    REACH_RTOL, REACH_COORDINATE_RTOL = 1e-2, 1e-5
    #: contacts per chunk of _reach_holds
    REACH_CHUNK = 8192

    def _reach_slack(self, box):
        return self.REACH_COORDINATE_RTOL * float(np.max(np.abs(np.concatenate([box.lower, box.upper]))))

    def _reach_holds(self, i, j, point, overlap, pos, radii, box):
        """_check_reach's test on the kept contacts only (one line per pair: the pairing already found the other
        line's point equal within rtol), without the minimum image where a point is within reach as it is, in
        chunks that stay in cache: the same test, 8 ms a frame of W1 where every line took 95. False if some
        contact fails it; _check_reach then finds its line."""
        walls = j < 0
        if np.any(walls):
            keep = np.flatnonzero(~walls)
            j_point, j_overlap, j = np.take(point, keep, axis=0), np.take(overlap, keep), np.take(j, keep)
        else:
            j_point, j_overlap = point, overlap
        slack, grow = self._reach_slack(box), 1 + self.REACH_RTOL
        step = self.REACH_CHUNK
        # (np.take copies a strided source, the .data table's columns, to contiguous memory at every call)
        pos, radii = np.ascontiguousarray(pos), np.ascontiguousarray(radii)
        for k, pts, dl in ((i, point, overlap), (j, j_point, j_overlap)):
            for a in range(0, k.size, step):
                kk = k[a:a + step]
                arm = np.take(pos, kk, axis=0)
                arm -= pts[a:a + step]
                reach = np.abs(dl[a:a + step])
                reach += np.take(radii, kk)
                reach *= grow
                reach += slack
                reach *= reach
                far = np.flatnonzero(row_squares(arm) > reach)
                if far.size and np.any(row_squares(box.minimum_image(np.take(arm, far, axis=0))) >
                                       np.take(reach, far)):
                    return False
        return True

    def _check_reach(self, rows, ints, line_of, time, pos, radii, box):
        """Refuse a line whose contact point lies outside particle i's (or the partner particle j's) sphere in the
        .data frame: such a line is not a contact of that particle, so the .fstat is from another run (or another
        frame of the same time), or its indices are damaged. The other checks miss it when the partner is fixed
        or a wall (those contacts are listed once)."""
        d = self.dim
        point = rows[:, 3:3 + d]
        delta = np.abs(rows[:, 6])
        slack = self._reach_slack(box)
        for column, side in ((0, "particle"), (1, "partner")):
            k = ints[:, column]
            lines = np.flatnonzero(k >= 0) if column else np.arange(k.size)
            if not lines.size:
                continue
            k = k[lines]
            arm = box.minimum_image(pos[k] - point[lines])
            reach = (radii[k] + delta[lines]) * (1 + self.REACH_RTOL) + slack
            far = np.flatnonzero(row_squares(arm) > reach * reach)
            if far.size:
                m = int(far[0])
                row = int(lines[m])
                self._check_periodic_reach(arm[m], reach[m], box, row, line_of, side, int(k[m]), time)
                raise ValueError(
                    f"{self.fstat_path}:{line_of(row)}: the contact point {point[row].tolist()} lies "
                    f"{math.sqrt(float(row_squares(arm[m:m + 1])[0])):.4g} from the centre of {side} {int(k[m])} "
                    f"(radius {radii[k[m]]:g}, overlap {rows[row, 6]:g}) in the frame at t = {time:g} of "
                    f"{self.data_path}: the line is not a contact of that particle, so the .fstat frame does not "
                    f"belong to this .data frame (files of different runs, or of a run restarted and appended to "
                    f"one file, or damaged indices); use the .data and .fstat that one run wrote")

    def _check_periodic_reach(self, arm, reach, box, row, line_of, side, k, time):
        """The cause of a far contact point when it is a contact across a face of an axis not known as periodic
        (no .restart, or periodic= without that axis): the point is at a box length from the particle."""
        lengths = np.asarray(box.lengths, float)
        wrapped = [a for a in range(self.dim) if not box.periodic[a] and abs(arm[a]) > 0.5 * lengths[a]]
        if not wrapped:
            return
        image = arm.copy()
        image[wrapped] -= lengths[wrapped] * np.round(image[wrapped] / lengths[wrapped])
        if float(np.sqrt(np.sum(image * image))) <= reach:
            names = ", ".join(box.axis_names[a] for a in wrapped)
            raise ValueError(f"{self.fstat_path}:{line_of(row)}: the contact point lies a box length from {side} {k} "
                             f"along {names} in the frame at t = {time:g}: a contact across a periodic face, but "
                             f"{names} is not periodic here (periodic = {box.periodic}); pass restart_path= (its "
                             f"PeriodicBoundary lines; --restart) or periodic=")

    def _fstat_problem(self, problem, detail, rows, ints, line_of, time, n):
        """The ValueError for a problem cg_fstat_contacts found (its codes: csrc/cg_fstat.h)."""
        path, d = self.fstat_path, self.dim
        k, q, a, b, count, df, dc, force_k, force_q = detail
        i, jraw = ints[:, 0], ints[:, 1]
        if problem == _FSTAT_TIME:
            return ValueError(f"{path}:{line_of(k)}: an interaction line of time {rows[k, 0]:g} in the frame of time "
                              f"{time:g}: the frame holds another frame's lines (a header line lost or inserted?); "
                              f"a damaged file, write it again")
        if problem == _FSTAT_PARTICLE:
            return ValueError(f"{path}:{line_of(k)}: particle index {i[k]} not in the .data frame ({n} particles)")
        if problem == _FSTAT_GHOST:
            return ValueError(f"{path}:{line_of(k)}: partner index {jraw[k]} >= {n} particles in the .data frame: "
                              "an interaction with a periodic ghost particle, which this reader does not support")
        if problem == _FSTAT_SELF:
            return ValueError(f"{path}:{line_of(k)}: particle {i[k]} in contact with itself")
        if problem == _FSTAT_FLAT:
            return ValueError(f"{path}:{line_of(k)}: the normal is perpendicular to (particle centre - contact "
                              "point); cannot tell its orientation")
        if problem == _FSTAT_REPEATED:
            ks = np.flatnonzero((jraw >= 0) & (np.minimum(i, jraw) == a) & (np.maximum(i, jraw) == b))
            return ValueError(f"{path}: the pair ({a}, {b}) is listed {count} times (lines "
                              f"{', '.join(str(line_of(int(m))) for m in ks)}); expected once from each side at most")
        if problem == _FSTAT_INCONSISTENT:
            return ValueError(f"{path}: lines {line_of(k)} and {line_of(q)} list the pair ({a}, {b}) inconsistently: "
                              f"forces {list(force_k[:d])} and {list(force_q[:d])} are not opposite or the contact "
                              f"points {rows[k, 3:3 + d].tolist()} and {rows[q, 3:3 + d].tolist()} differ (|f1 + f2| "
                              f"= {df:.3g}, |c1 - c2| = {dc:.3g}, rtol = {self.rtol:g})")
        if problem == _FSTAT_ONCE:
            return ValueError(f"{path}:{line_of(k)}: the pair ({i[k]}, {jraw[k]}) of two flowing particles is listed "
                              "once; MercuryDPM writes such a contact from both sides, so a line of the file was lost "
                              "(a truncated or edited file?) or the fixed particles are wrong (check fixed= or the "
                              ".restart file)")
        raise AssertionError(f"cg_fstat_contacts: unknown problem {problem}")
