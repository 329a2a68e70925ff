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
the same side, is an error too. The kept orientation is i < j. Walls become ``j = -1``
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
``PeriodicBoundary ... normal nx ny nz`` lines of the ``.restart``.

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
  (within 1e-9 relative) raises; unmatched ``.fstat`` frames are ignored.
"""
import math
import numbers
import os

import numpy as np

from ..box import Box
from ..snapshot import Contacts, Snapshot
from ._sequence import FrameSequence
from .files import open_input

__all__ = ["MercuryReader", "MercuryFrame", "write_mercury"]

_DATA_COLUMNS = {3: 14, 2: 8}
_FSTAT_COLUMNS = 16


# ----------------------------------------------------------------------------------------------
# scanning

def _floats(words, path, lineno):
    try:
        return [float(w) for w in words]
    except ValueError:
        raise ValueError(f"{path}:{lineno}: expected numbers, got {' '.join(words)[:80]!r}") from None


def _scan_data(path, dim):
    """Frames of a .data file: list of (byte offset of the header, line number, n, time, dim)."""
    frames = []
    with open_input(path) as fh:
        lineno = 0
        while True:
            offset = fh.tell()
            line = fh.readline()
            lineno += 1
            if not line:
                break
            words = line.split()
            if not words or words[0].startswith(b"#"):
                continue
            head = _floats([w.decode() for w in words], path, lineno)
            if len(head) not in (6, 8):
                raise ValueError(f"{path}:{lineno}: expected a header 'N time xmin ymin [zmin] xmax ymax [zmax]' "
                                 f"(6 values in 2D, 8 in 3D), got {len(head)} values")
            d = 3 if len(head) == 8 else 2
            if dim is not None and d != dim:
                raise ValueError(f"{path}:{lineno}: a {d}D header, but dim={dim} was given")
            n = head[0]
            if n != int(n) or n < 0:
                raise ValueError(f"{path}:{lineno}: expected a particle count, got {words[0].decode()!r}")
            n = int(n)
            frames.append((offset, lineno, n, head[1], d))
            for _ in range(n):
                row = fh.readline()
                lineno += 1
                if not row.endswith(b"\n") and not row.strip():
                    raise ValueError(f"{path}: truncated frame at t = {head[1]}: expected {n} particle lines")
    return frames


def _scan_fstat(path):
    """Frames of a .fstat file: list of (byte offset of the first header line, line number, time, marker)."""
    frames = []
    with open_input(path) as fh:
        lineno = 0
        in_header = 0   # header lines seen in the current block (3 per frame)
        while True:
            offset = fh.tell()
            line = fh.readline()
            lineno += 1
            if not line:
                break
            if line.startswith(b"#"):
                if in_header in (0, 3):
                    words = line[1:].split()
                    vals = _floats([w.decode() for w in words[:2]], path, lineno)
                    if not vals:
                        raise ValueError(f"{path}:{lineno}: expected '# time marker', got {line[:60]!r}")
                    marker = int(vals[1]) if len(vals) > 1 else 0
                    frames.append((offset, lineno, vals[0], marker))
                    in_header = 0
                in_header += 1
                continue
            in_header = 0
            if line.strip() and not frames:
                raise ValueError(f"{path}:{lineno}: contact line before the first '# time' header")
    return frames


def _read_restart(path):
    """Key-based parse of a .restart: species densities, the particles' invMass and positions (by id),
    periodic normals.

    Particles are the lines of the ``Particles N`` section whose first word names a particle class
    (``BaseParticle``, ``SphericalParticle``, ...); other lines with particle keys, such as the
    template particle embedded in an insertion boundary's line, are not particles. A section with
    fewer than N particle lines (a truncated file) is an error.
    """
    density, normals, particle_dim = {}, [], None
    inv_mass, positions = [], []
    declared, declared_line = None, None
    with open_input(path, text=True) as fh:
        for lineno, line in enumerate(fh, 1):
            words = line.split()
            if not words:
                continue
            keys = {w: k for k, w in reversed(list(enumerate(words)))}

            def val(key, n=1):
                k = keys[key]
                return [float(x) for x in words[k + 1:k + 1 + n]]

            if words[0] == "Particles" and len(words) == 2 and words[1].isdigit():
                declared, declared_line = int(words[1]), lineno
                continue
            try:
                if "particleDimensions" in keys:
                    particle_dim = int(val("particleDimensions")[0])
                if "density" in keys and "id" in keys and words[0].endswith("Species"):
                    density[int(val("id")[0])] = val("density")[0]
                elif words[0].endswith("Particle") and "invMass" in keys and "position" in keys:
                    inv_mass.append(val("invMass")[0])
                    positions.append(val("position", 3))
                elif words[0] == "PeriodicBoundary" and "normal" in keys:
                    normals.append(val("normal", 3))
            except (ValueError, IndexError):
                raise ValueError(f"{path}:{lineno}: cannot read the values of this {words[0]} line "
                                 f"(a damaged .restart?)") from None
    if declared is not None and len(inv_mass) != declared:
        raise ValueError(f"{path}:{declared_line}: 'Particles {declared}' but {len(inv_mass)} particle lines follow "
                         f"(a truncated or damaged .restart); write it again, or pass fixed= instead")
    # the file's order is the particle handler's, which is the order of the .data rows
    return {"density": density, "inv_mass": np.array(inv_mass, dtype=float),
            "positions": np.array(positions, dtype=float).reshape(-1, 3), "normals": normals,
            "particle_dim": particle_dim}


# ----------------------------------------------------------------------------------------------

class MercuryFrame:
    """One frame: ``snapshot`` plus ``wall_index`` ((M,) MercuryDPM wall index, -1 for pairs),
    ``overlap`` ((M,) delta), ``data_line`` and ``fstat_line`` (line numbers of the frame headers)."""

    def __init__(self, snapshot, wall_index, overlap, data_line, fstat_line):
        self.snapshot = snapshot
        self.wall_index = wall_index
        self.overlap = overlap
        self.data_line = data_line
        self.fstat_line = fstat_line


class MercuryReader(FrameSequence):
    """Lazy sequence of :class:`cgbound.Snapshot` from MercuryDPM output (see the module docstring).

    Parameters
    ----------
    data_path : path
        The ``.data`` file (XBalls format 14 in 3D, 8 in 2D).
    fstat_path : path, optional
        The ``.fstat`` file; without it frames have no contacts.
    restart_path : path, optional
        The ``.restart`` file: species densities, fixed particles, periodic axes.
    fixed : indices, (N,) bools, or callable(radius, species) -> (N,) bools, optional
    body_force : (D,) body force per unit mass on flowing particles, cgbound axes
        (in 2D also the 3 MercuryDPM components, third 0).
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
    """

    def __init__(self, data_path, fstat_path=None, *, restart_path=None, fixed=None, body_force=None, dim=None,
                 density=None, particle_dim=None, periodic=None, rtol=1e-9):
        if dim is not None and dim not in (2, 3):
            raise ValueError(f"dim: expected 2 or 3, got {dim!r}")
        self.data_path = os.path.abspath(os.fspath(data_path))
        self.fstat_path = None if fstat_path is None else os.path.abspath(os.fspath(fstat_path))
        self.restart_path = None if restart_path is None else os.path.abspath(os.fspath(restart_path))
        data_frames = _scan_data(self.data_path, dim)
        dims = {f[4] for f in data_frames}
        if len(dims) > 1:
            raise ValueError(f"{self.data_path}: mixes 2D and 3D headers")
        self.dim = dim if dim is not None else (dims.pop() if dims else 3)
        restart = _read_restart(self.restart_path) if self.restart_path else None
        self._restart = None if restart is None else {"inv_mass": restart["inv_mass"],
                                                      "positions": restart["positions"]}
        self.density = self._densities(density, restart)
        pdim = particle_dim if particle_dim is not None else (restart or {}).get("particle_dim")
        self.particle_dim = int(pdim) if pdim is not None else self.dim
        if self.particle_dim not in (2, 3):
            raise ValueError(f"particle_dim: expected 2 or 3, got {pdim!r}")
        self.fixed = fixed if callable(fixed) or fixed is None else np.asarray(fixed)
        self.body_force = self._check_body_force(body_force)
        self.periodic = self._periodic(periodic, restart)
        if not (isinstance(rtol, numbers.Real) and rtol >= 0):
            raise ValueError(f"rtol: expected a non-negative number, got {rtol!r}")
        self.rtol = float(rtol)
        self._frames = self._match(data_frames)
        self._cache = None

    # ------------------------------------------------------------------------------------------
    def _densities(self, density, restart):
        if density is None:
            dens = dict(restart["density"]) if restart else {}
            return dens or None
        if isinstance(density, dict):
            return {int(k): float(v) for k, v in density.items()}
        if isinstance(density, numbers.Real) and not isinstance(density, bool):
            return float(density)
        raise ValueError(f"density: expected a number or a dict species -> density, got {density!r}")

    def _check_body_force(self, g):
        if g is None:
            return None
        g = np.asarray(g, dtype=float)
        if self.dim == 2 and g.shape == (3,):
            if g[2] != 0:
                raise ValueError("body_force: a 2D MercuryDPM run has no z component; got a non-zero third value")
            g = g[:2]
        if g.shape != (self.dim,) or not np.all(np.isfinite(g)):
            raise ValueError(f"body_force: expected {self.dim} finite values, got {g.tolist()}")
        return g

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
        if self.fstat_path is None:
            return [(d[0], d[1], d[2], None, None, None) for d in data_frames]
        fst = _scan_fstat(self.fstat_path)
        times = np.array([f[2] for f in fst])
        out, missing = [], []
        for off, line, n, t, _ in data_frames:
            if times.size:
                k = int(np.argmin(np.abs(times - t)))
                if abs(times[k] - t) <= 1e-9 * max(1.0, abs(t)):
                    out.append((off, line, n, fst[k][0], fst[k][1], fst[k][3]))
                    continue
            missing.append(t)
        if missing:
            raise ValueError(f"{self.fstat_path}: no .fstat frame for time(s) {missing[:10]} of {self.data_path}")
        return out

    # ------------------------------------------------------------------------------------------
    def _snapshot(self, position):
        return self.frame(position).snapshot

    def __repr__(self):
        return (f"MercuryReader({os.path.basename(self.data_path)!r}, "
                f"{None if self.fstat_path is None else os.path.basename(self.fstat_path)!r}, "
                f"{len(self)} frames, {self.dim}D)")

    def frame(self, index):
        """Frame ``index`` as a :class:`MercuryFrame`."""
        return self._cached_frame(index)

    # ------------------------------------------------------------------------------------------
    def _build(self, data_offset, data_line, n, fstat_offset, fstat_line, marker):
        path, dim = self.data_path, self.dim
        ncol = _DATA_COLUMNS[dim]
        with open_input(path) as fh:
            fh.seek(data_offset)
            head = fh.readline().split()
            rows = [fh.readline() for _ in range(n)]
        time = float(head[1])
        hv = [float(w) for w in head[2:]]
        lower, upper = np.array(hv[:dim]), np.array(hv[dim:2 * dim])
        table = np.zeros((n, ncol))
        for k, row in enumerate(rows):
            words = row.split()
            if len(words) < ncol:
                raise ValueError(f"{path}:{data_line + 1 + k}: expected {ncol} columns for a {dim}D .data "
                                 f"particle line, got {len(words)}")
            table[k] = _floats([w.decode() for w in words[:ncol]], path, data_line + 1 + k)
        if dim == 3:
            pos, vel, radii, species = table[:, 0:3], table[:, 3:6], table[:, 6], table[:, 13]
        else:
            pos, vel, radii, species = table[:, 0:2], table[:, 2:4], table[:, 4], table[:, 7]
        if np.any(species != np.round(species)) or np.any(species < 0):
            raise ValueError(f"{path}: frame at line {data_line}: the species column holds non-integers")
        species = species.astype(np.int64)
        box = Box(np.minimum(lower, upper), np.maximum(lower, upper), self.periodic)
        fixed = self._fixed(radii, species, n, pos, time)
        masses = self._masses(radii, species, fixed)
        if fstat_offset is not None:
            contacts, wall_index, overlap = self._contacts(fstat_offset, fstat_line, marker, time, pos, radii, box)
        else:
            contacts, wall_index, overlap = Contacts.empty(dim), np.zeros(0, np.int64), np.zeros(0)
        snap = Snapshot(pos, velocities=vel, masses=masses, box=box, contacts=contacts, fixed=fixed,
                        species=species, body_force=self.body_force, radii=radii, time=time)
        return MercuryFrame(snap, wall_index, overlap, data_line, fstat_line)

    def _fixed(self, radii, species, n, positions, time):
        f = self.fixed
        if callable(f):
            out = np.asarray(f(radii, species), dtype=bool)
            if out.shape != (n,):
                raise ValueError(f"fixed: the callable returned shape {out.shape}, expected ({n},)")
            return out
        if f is not None:
            if f.dtype == bool:
                if f.shape != (n,):
                    raise ValueError(f"fixed: expected {n} bools, got shape {f.shape}")
                return f.copy()
            out = np.zeros(n, bool)
            idx = f.astype(np.int64).ravel()
            if np.any((idx < 0) | (idx >= n)):
                raise IndexError(f"fixed: indices must lie in [0, {n})")
            out[idx] = True
            return out
        if self._restart is None:
            return np.zeros(n, bool)
        return self._fixed_from_restart(n, positions, time)

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

    def _contacts(self, offset, first_line, marker, time, pos, radii, box):
        path, dim, n = self.fstat_path, self.dim, pos.shape[0]
        lines, numbers_ = [], []
        with open_input(path) as fh:
            fh.seek(offset)
            lineno = first_line - 1
            seen_data, headers = False, 0
            while True:
                line = fh.readline()
                lineno += 1
                if not line:
                    break
                if line.startswith(b"#"):
                    headers += 1
                    if seen_data or headers > 3:
                        break
                    continue
                if not line.strip():
                    continue
                seen_data = True
                words = line.split()
                if len(words) < _FSTAT_COLUMNS:
                    raise ValueError(f"{path}:{lineno}: expected {_FSTAT_COLUMNS} columns "
                                     "'time i j cx cy cz delta deltat fn ft nx ny nz tx ty tz', got "
                                     f"{len(words)}")
                lines.append(_floats([w.decode() for w in words[:_FSTAT_COLUMNS]], path, lineno))
                numbers_.append(lineno)
        if not lines:
            return Contacts.empty(dim), np.zeros(0, np.int64), np.zeros(0)
        t = np.array(lines)
        lnum = np.array(numbers_)
        i = t[:, 1].astype(np.int64)
        jraw = t[:, 2].astype(np.int64)
        if np.any(t[:, 1] != i) or np.any(t[:, 2] != jraw):
            k = int(np.flatnonzero((t[:, 1] != i) | (t[:, 2] != jraw))[0])
            raise ValueError(f"{path}:{lnum[k]}: particle indices must be integers")
        axes = [0, 1] if dim == 2 else [0, 1, 2]
        point = t[:, 3:6][:, axes]
        overlap = t[:, 6]
        fn, ft = t[:, 8], t[:, 9]
        normal, tang = t[:, 10:13][:, axes], t[:, 13:16][:, axes]
        bad = (i < 0) | (i >= n)
        if np.any(bad):
            k = int(np.flatnonzero(bad)[0])
            raise ValueError(f"{path}:{lnum[k]}: particle index {i[k]} not in the .data frame ({n} particles)")
        bad = jraw >= n
        if np.any(bad):
            k = int(np.flatnonzero(bad)[0])
            raise ValueError(f"{path}:{lnum[k]}: partner index {jraw[k]} >= {n} particles in the .data frame: "
                             "an interaction with a periodic ghost particle, which this reader does not support")
        if np.any(jraw == i):
            k = int(np.flatnonzero(jraw == i)[0])
            raise ValueError(f"{path}:{lnum[k]}: particle {i[k]} in contact with itself")
        # force on i: s (fn n + ft t), s = sign(n . (x_i - c)) (see the module docstring)
        arm = pos[i] - point
        for a, per in enumerate(box.periodic):
            if per:
                L = box.upper[a] - box.lower[a]
                arm[:, a] -= L * np.round(arm[:, a] / L)
        proj = np.sum(normal * arm, axis=1)
        nonzero_force = (fn != 0) | (ft != 0)
        flat = (np.abs(proj) <= 1e-12 * np.maximum(np.linalg.norm(arm, axis=1), 1e-300)) & nonzero_force
        if np.any(flat):
            k = int(np.flatnonzero(flat)[0])
            raise ValueError(f"{path}:{lnum[k]}: the normal is perpendicular to (particle centre - contact point); "
                             "cannot tell its orientation")
        sign = np.where(proj < 0, -1.0, 1.0)
        force = sign[:, None] * (fn[:, None] * normal + ft[:, None] * tang)

        # merge double listings of pairs
        wall = jraw < 0
        pair = ~wall
        keep = wall.copy()
        scale = float(np.max(np.linalg.norm(force, axis=1))) if len(force) else 0.0
        lscale = 2.0 * float(np.max(radii)) if radii.size else 1.0
        lo, hi = np.minimum(i, jraw), np.maximum(i, jraw)
        groups = {}
        for k in np.flatnonzero(pair):
            groups.setdefault((int(lo[k]), int(hi[k])), []).append(int(k))
        for (a, b), ks in groups.items():
            if len(ks) == 1:
                keep[ks[0]] = True
                continue
            if len(ks) > 2 or i[ks[0]] == i[ks[1]]:
                raise ValueError(f"{path}: the pair ({a}, {b}) is listed {len(ks)} times (lines "
                                 f"{', '.join(str(lnum[k]) for k in ks)}); expected once from each side at most")
            k1, k2 = ks
            df = np.linalg.norm(force[k1] + force[k2])
            dc = np.linalg.norm(point[k1] - point[k2])
            if df > self.rtol * max(scale, 1e-300) or dc > self.rtol * lscale:
                raise ValueError(f"{path}: lines {lnum[k1]} and {lnum[k2]} list the pair ({a}, {b}) inconsistently: "
                                 f"forces {force[k1].tolist()} and {force[k2].tolist()} are not opposite or the "
                                 f"contact points {point[k1].tolist()} and {point[k2].tolist()} differ (|f1 + f2| = {df:.3g}, "
                                 f"|c1 - c2| = {dc:.3g}, rtol = {self.rtol:g})")
            keep[k1 if i[k1] < i[k2] else k2] = True
        sel = np.flatnonzero(keep)
        j = np.where(wall, -1, jraw)[sel]
        wall_index = np.where(wall, -1 - jraw, -1)[sel]
        return Contacts(i[sel], j, force[sel], point[sel]), wall_index, overlap[sel]


# ----------------------------------------------------------------------------------------------

def write_mercury(snapshots, data_path, fstat_path, *, precision=17, wall_index=None):
    """Write snapshots as MercuryDPM ``.data`` and ``.fstat`` files (the layouts of the module docstring).

    Radii are required. Pairs of flowing particles are written twice (as ``writeToFStat`` does),
    pairs with a fixed particle once from the flowing side, walls once with the flipped normal
    and tangent of ``writeToFStat``. Orientation, angular velocity and the tangential overlap are
    written as 0. ``wall_index`` (callable(snapshot) -> (M,) ints, optional) gives the MercuryDPM
    wall index of each wall contact (default 0). Returns the number of frames written.
    """
    count = 0
    fmt = f"%.{int(precision)}g"

    def vec(v):
        return " ".join(fmt % x for x in v)

    with open(data_path, "w") as fd, open(fstat_path, "w") as ff:
        for snap in snapshots:
            dim, n = snap.dim, snap.n_particles
            if snap.radii is None:
                raise ValueError("write_mercury: snapshots need radii")
            vel = snap.velocities if snap.velocities is not None else np.zeros((n, dim))
            species = snap.species if snap.species is not None else np.zeros(n, np.int64)
            lo, hi = snap.box.lower, snap.box.upper
            fd.write(f"{n} {fmt % snap.time} {vec(lo)} {vec(hi)}\n")
            for k in range(n):
                if dim == 3:
                    fd.write(f"{vec(snap.positions[k])} {vec(vel[k])} {fmt % snap.radii[k]} 0 0 0 0 0 0 {species[k]}\n")
                else:
                    fd.write(f"{vec(snap.positions[k])} {vec(vel[k])} {fmt % snap.radii[k]} 0 0 {species[k]}\n")
            lo3 = list(lo) + [0.0] * (3 - dim)
            hi3 = list(hi) + [0.0] * (3 - dim)
            ff.write(f"# {fmt % snap.time} 1\n# {vec(lo3)} {vec(hi3)}\n")
            ff.write(f"# {fmt % float(np.min(snap.radii))} {fmt % float(np.max(snap.radii))} 0 0 0 0\n")
            c = snap.contacts
            widx = np.zeros(len(c), np.int64) if wall_index is None else np.asarray(wall_index(snap))
            periodic, L = snap.box.periodic, snap.box.upper - snap.box.lower

            def mi(d):
                d = np.array(d, float)
                for a in range(dim):
                    if periodic[a]:
                        d[a] -= L[a] * np.round(d[a] / L[a])
                return d

            for k in range(len(c)):
                i, j, f, p = int(c.i[k]), int(c.j[k]), c.force[k], c.point[k]
                if j < 0:
                    if snap.fixed[i]:
                        continue
                    arm = mi(snap.positions[i] - p)
                    nrm = arm / np.linalg.norm(arm)       # from the wall to the particle
                    delta = 2.0 * (snap.radii[i] - np.linalg.norm(arm))
                    ff.write(_fstat_line(fmt, vec, snap.time, i, -1 - int(widx[k]), p, nrm, f, delta, dim, wall=True))
                    continue
                r = mi(snap.positions[i] - snap.positions[j])
                nrm = r / np.linalg.norm(r)               # from j to i
                delta = snap.radii[i] + snap.radii[j] - np.linalg.norm(r)
                if not snap.fixed[i]:
                    ff.write(_fstat_line(fmt, vec, snap.time, i, j, p, nrm, f, delta, dim))
                if not snap.fixed[j]:
                    ff.write(_fstat_line(fmt, vec, snap.time, j, i, p, -nrm, -f, delta, dim))
            count += 1
    return count


def _fstat_line(fmt, vec, time, i, j, point, nrm, f, delta, dim, wall=False):
    """One .fstat line: fn, ft of the force on particle i along the normal ``nrm`` (j -> i).
    Wall lines are written as writeToFStat does, with ``-nrm`` and ``-t``."""
    fn = float(np.dot(f, nrm))
    tv = f - fn * nrm
    ftv = float(np.linalg.norm(tv))
    tt = tv / ftv if ftv > 0 else np.zeros(dim)
    sign = -1.0 if wall else 1.0
    pad = [0.0] * (3 - dim)
    return (f"{fmt % time} {i} {j} {vec(list(point) + pad)} {fmt % delta} 0 {fmt % fn} {fmt % ftv} "
            f"{vec(list(sign * nrm) + pad)} {vec(list(sign * tt) + pad)}\n")
