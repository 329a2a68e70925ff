"""Read any MDAnalysis trajectory as a lazy sequence of :class:`cgbound.Snapshot`.

MDAnalysis (https://www.mdanalysis.org) reads dozens of simulation formats (GROMACS, LAMMPS
DATA/DCD, NAMD/CHARMM, AMBER, PDB, XYZ, ...). :class:`MDAnalysisReader` turns the frames of a
``Universe`` into Snapshots:

* positions and velocities (None when the trajectory has none) of the selected atoms, converted
  to float64 from MDAnalysis's float32 without any other change;
* masses from the topology (``AtomGroup.masses``; MDAnalysis guesses them from the atom types
  when the topology does not give them);
* radii from the topology when it has them (e.g. PQR files), else None;
* the box from ``ts.dimensions``: ``lower = 0``, ``upper = (a, b, c)``, periodic on every axis.
  Only orthorhombic boxes (all angles 90 degrees) are supported; a triclinic box raises a
  ValueError. A trajectory without a box gives the non-periodic bounding box of the positions
  (chosen by :class:`cgbound.Snapshot`);
* the time from ``ts.time``.

Units: cgbound keeps the trajectory's units as MDAnalysis reports them, i.e. MDAnalysis's base
units: lengths in Angstrom, time in ps, velocities in Angstrom/ps, masses in u (g/mol), forces
in kJ/(mol Angstrom). The fields come out in the matching units (density in u/Angstrom^3, ...);
nothing is converted. Note that kJ/mol is not u Angstrom^2/ps^2 (1 kJ/mol = 100 u A^2/ps^2),
so contact forces from ``forces()`` must be converted by the caller before they are mixed with
kinetic terms.

The per-atom forces of the trajectory (when it has them) are kept accessible through
:meth:`MDAnalysisReader.forces`; they are not contacts. Contacts come from an optional callable
``contacts(frame, snapshot) -> cg.Contacts``; without it the Snapshots have no contacts and only
the particle fields (density, momentum, velocity, kinetic stress, ...) can be computed.

MDAnalysis is imported only when a reader is created.
"""
import os

import numpy as np

from .._validate import flag
from ..box import Box
from ..snapshot import Contacts, Snapshot
from ._sequence import FrameSequence

__all__ = ["MDAnalysisReader"]

_ANGLE_TOL = 1e-4  # degrees; MDAnalysis stores float32 angles


def _mda():
    try:
        import MDAnalysis
    except ImportError as exc:
        raise ImportError("reading MDAnalysis trajectories needs MDAnalysis: pip install MDAnalysis") from exc
    return MDAnalysis


def _as_args(universe_or_args):
    """Normalise constructor arguments: (tuple of positional args, dict of keywords)."""
    if isinstance(universe_or_args, (str, bytes, os.PathLike)):
        return (os.fspath(universe_or_args),), {}
    if isinstance(universe_or_args, dict):
        kwargs = dict(universe_or_args)
        args = kwargs.pop("args", ())
        if isinstance(args, (str, bytes, os.PathLike)):
            args = (args,)
        return tuple(os.fspath(a) if isinstance(a, os.PathLike) else a for a in args), kwargs
    if isinstance(universe_or_args, (tuple, list)):
        if not universe_or_args:
            raise ValueError("universe_or_args: expected a Universe, a file name or a tuple of file names, got ()")
        return tuple(os.fspath(a) if isinstance(a, os.PathLike) else a for a in universe_or_args), {}
    raise TypeError(f"universe_or_args: expected an MDAnalysis Universe, a file name, a tuple of file names "
                    f"(topology, trajectory, ...) or a dict of Universe arguments, got "
                    f"{type(universe_or_args).__name__}")


class MDAnalysisReader(FrameSequence):
    """Lazy sequence of :class:`cgbound.Snapshot` from an MDAnalysis Universe (see the module docstring).

    ``len()``, integer indexing (negative allowed) and slicing (giving another reader over the
    selected frames) work like a list. Reading frame k moves the Universe's trajectory to it.

    Parameters
    ----------
    universe_or_args : Universe, path, tuple of paths, or dict
        An ``MDAnalysis.Universe``, or the arguments to build one: a file name, a tuple
        ``(topology, trajectory, ...)`` passed as ``Universe(*args)``, or a dict of keywords for
        ``Universe`` (positional arguments under the key ``"args"``). When built from arguments
        the reader pickles the arguments, not the Universe, and rebuilds it lazily; a given
        Universe is pickled by MDAnalysis itself (file-based trajectories reopen their files,
        in-memory ones carry their arrays).
    select : str
        Atom selection (MDAnalysis selection language) of the particles to use; evaluated once,
        on the frame the Universe is at when the reader is created, and then fixed.
    fixed : str or (n,) bool array, optional
        Boundary particles: a selection string (evaluated like ``select``, on the whole Universe;
        selected atoms it contains are fixed), or booleans over the selected atoms (or over all
        atoms of the Universe).
    contacts : callable, optional
        ``contacts(frame, snapshot) -> cg.Contacts``, with ``frame`` the trajectory frame number
        (``ts.frame``) and ``snapshot`` the contact-free Snapshot of that frame (particle indices
        refer to the selected atoms, in selection order). Must be picklable to pickle the reader.
    body_force : (D,) array, optional
        Body force per unit mass (e.g. gravity) on the flowing particles.
    dimension : 2 or 3
        With 2, the x and y coordinates become cgbound's 2D axes (x, z); z is ignored.
    wrap : bool
        Wrap positions into the box along periodic axes (default True). Positions already
        inside ``[0, L)`` are unchanged.
    """

    def __init__(self, universe_or_args, select="all", fixed=None, contacts=None, body_force=None, dimension=3,
                 wrap=True, units=None):
        self.units = units
        mda = _mda()
        if isinstance(dimension, bool) or dimension not in (2, 3):
            raise ValueError(f"dimension: expected 2 or 3, got {dimension!r}")
        self.dimension = int(dimension)
        if isinstance(universe_or_args, mda.Universe):
            self._args = None
            self._universe = universe_or_args
        else:
            self._args = _as_args(universe_or_args)
            self._universe = None
        u = self.universe
        if not isinstance(select, str):
            raise TypeError(f"select: expected a selection string, got {type(select).__name__}")
        self.select = select
        try:
            group = u.select_atoms(select)
        except Exception as exc:  # MDAnalysis raises SelectionError (a ValueError) and others
            raise ValueError(f"select: invalid selection {select!r}: {exc}") from exc
        if group.n_atoms == 0:
            raise ValueError(f"select: the selection {select!r} matches no atoms")
        self.indices = np.asarray(group.indices, dtype=np.int64)
        self.fixed = self._check_fixed(u, fixed)
        if contacts is not None and not callable(contacts):
            raise TypeError(f"contacts: expected a callable (frame, snapshot) -> cg.Contacts or None, "
                            f"got {type(contacts).__name__}")
        self.contacts = contacts
        self.body_force = self._check_body_force(body_force, self.dimension)
        self.wrap = flag(wrap, "wrap")
        self.masses = self._masses(group)
        self.radii = self._radii(group)
        self._frames = list(range(len(u.trajectory)))

    # ------------------------------------------------------------------------------------------
    @property
    def universe(self):
        """The MDAnalysis Universe (rebuilt from the stored arguments after unpickling)."""
        if self._universe is None:
            mda = _mda()
            args, kwargs = self._args
            try:
                self._universe = mda.Universe(*args, **kwargs)
            except Exception as exc:
                msg = f"universe_or_args: MDAnalysis could not open {args!r}: {exc}"
                try:
                    wrapped = type(exc)(msg)
                except Exception:  # an exception type with another constructor
                    wrapped = ValueError(msg)
                raise wrapped from exc
        return self._universe

    @property
    def atoms(self):
        """The selected AtomGroup."""
        return self.universe.atoms[self.indices]

    def _check_fixed(self, u, fixed):
        n = self.indices.size
        if fixed is None:
            return np.zeros(n, bool)
        if isinstance(fixed, str):
            try:
                fg = u.select_atoms(fixed)
            except Exception as exc:
                raise ValueError(f"fixed: invalid selection {fixed!r}: {exc}") from exc
            selected = np.isin(self.indices, fg.indices)
            if not selected.any():
                raise ValueError(f"fixed: the selection {fixed!r} selects none of the {n} atoms of select= "
                                 f"({fg.n_atoms} atoms of the whole universe); check the selection")
            return selected
        arr = np.asarray(fixed)
        if arr.dtype != bool or arr.ndim != 1:
            raise TypeError(f"fixed: expected a selection string or a 1-D bool array, got {arr.dtype} "
                            f"array of shape {arr.shape}")
        if arr.shape[0] == n:
            return arr.copy()
        if arr.shape[0] == u.atoms.n_atoms:
            return arr[self.indices].copy()
        raise ValueError(f"fixed: expected {n} bools (the selected atoms) or {u.atoms.n_atoms} (all atoms), "
                         f"got {arr.shape[0]}")

    def _masses(self, group):
        try:
            masses = np.asarray(group.masses, dtype=float)
        except Exception as exc:  # NoDataError
            raise ValueError("universe_or_args: the topology has no masses; add them with "
                             "universe.add_TopologyAttr('masses', values)") from exc
        bad = ~self.fixed & ~(masses > 0)
        if np.any(bad):
            k = int(np.flatnonzero(bad)[0])
            raise ValueError(f"universe_or_args: atom {int(self.indices[k])} has mass {masses[k]}; flowing "
                             "particles need positive masses (set them with add_TopologyAttr('masses', ...), "
                             "or mark the atom fixed)")
        # fixed particles: infinite mass, value ignored; keep the array valid
        return np.where(self.fixed & ~(masses > 0), 1.0, masses)

    @staticmethod
    def _radii(group):
        try:
            radii = np.asarray(group.radii, dtype=float)
        except Exception:  # NoDataError: no radii in the topology
            return None
        return radii

    # ------------------------------------------------------------------------------------------
    @property
    def frames(self):
        """Trajectory frame numbers of this reader's frames."""
        return list(self._frames)

    def __getstate__(self):
        state = super().__getstate__()
        if self._args is not None:
            state["_universe"] = None  # rebuilt lazily from the arguments
        return state

    def _describe(self):
        src = "Universe" if self._args is None else repr(self._args[0])
        return [src, f"select={self.select!r}"], [f"{self.indices.size} atoms", f"{self.dimension}D"]

    # ------------------------------------------------------------------------------------------
    def _frame_number(self, index):
        return self._frames[self._position(index)]

    def _timestep(self, index):
        return self.universe.trajectory[self._frame_number(index)]

    def _axes(self):
        return [0, 1] if self.dimension == 2 else [0, 1, 2]

    def _box(self, ts):
        dims = ts.dimensions
        if dims is None:
            return None
        dims = np.asarray(dims, dtype=float)
        lengths, angles = dims[:3], dims[3:6]
        if not np.all(lengths > 0):
            return None  # some formats write a zero box for "no box"
        if np.any(np.abs(angles - 90.0) > _ANGLE_TOL):
            raise ValueError(f"universe_or_args: frame {ts.frame} has a triclinic box (angles "
                             f"{angles.tolist()}); only orthorhombic boxes (all angles 90) are supported")
        upper = lengths[self._axes()]
        return Box(np.zeros(self.dimension), upper, periodic=True)

    def _snapshot(self, position):
        return self.snapshot(position)

    def snapshot(self, index):
        """Frame ``index`` of this reader as a Snapshot (same as ``reader[index]``)."""
        ts = self._timestep(index)
        axes = self._axes()
        idx = self.indices
        pos = np.asarray(ts.positions[idx][:, axes], dtype=float)
        vel = np.asarray(ts.velocities[idx][:, axes], dtype=float) if ts.has_velocities else None
        box = self._box(ts)
        if box is not None and self.wrap:
            pos = box.wrap(pos)
        snap = Snapshot(pos, velocities=vel, masses=self.masses, box=box, fixed=self.fixed,
                        body_force=self.body_force, radii=self.radii, time=float(ts.time))
        if self.contacts is not None:
            c = self.contacts(int(ts.frame), snap)
            if c is not None:
                if not isinstance(c, Contacts):
                    raise TypeError(f"contacts: the callable returned a {type(c).__name__} for frame {ts.frame}, "
                                    "expected a cg.Contacts")
                snap = Snapshot(pos, velocities=vel, masses=self.masses, box=snap.box, contacts=c,
                                fixed=self.fixed, body_force=self.body_force, radii=self.radii, time=snap.time)
        return snap

    def forces(self, index):
        """The trajectory's per-atom forces of frame ``index`` ((n, D) float64, selected atoms, in
        the trajectory's units); ValueError when the trajectory has no forces."""
        ts = self._timestep(index)
        if not ts.has_forces:
            raise ValueError(f"forces: the trajectory has no forces (frame {ts.frame})")
        return np.asarray(ts.forces[self.indices][:, self._axes()], dtype=float)

    def time(self, index):
        """The time of frame ``index`` (``ts.time``, ps in MDAnalysis)."""
        return float(self._timestep(index).time)
