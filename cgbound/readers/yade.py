"""Read Yade frames written by :mod:`cgbound.readers.yade_export` as a lazy sequence of Snapshots.

Recipe (inside Yade; ``yade_export.py`` needs numpy only, so cgbound need not be installed there)::

    exec(open("/path/to/cgbound/readers/yade_export.py").read())
    O.engines = [..., NewtonIntegrator(gravity=(0, 0, -9.81)),
                 PyRunner(command='export_frame("frames")', iterPeriod=1000)]   # LAST engine

then ``YadeReader("frames")`` (a directory), ``YadeReader("frames/yade_*.npz")`` (a pattern) or a
list of files. Frames are ordered by Yade's iteration number.

How Yade's data becomes a Snapshot:

* particles are the spherical bodies (clump members included; the clump bodies themselves, which
  have no shape, are not particles; a clump's mass is shared by its members in proportion to their own
  masses, so the members carry the clump's mass and momentum). Non-spherical bodies (``Wall``, ``Facet``, ``Box``, ...) are
  walls: their contacts become boundary contacts with ``j = -1``. A sphere is fixed (boundary) when
  it is not ``dynamic`` or its three translational DOFs are blocked (``blockedDOFs`` contains x, y
  and z); a clump member takes the flags of its clump. Partly blocked translation (e.g. ``"z"``)
  is refused: such a particle is neither flowing nor boundary.
* Yade applies ``i.phys.normalForce + i.phys.shearForce`` ON ``id2`` FROM ``id1`` (verified:
  a sphere resting on a fixed sphere below it has ``normalForce`` pointing up, id1 = the lower
  one, and ``O.forces.f(id2)`` equals it). cgbound's ``Contacts`` hold the force ON ``i`` FROM
  ``j``, so ``i = id2, j = id1``; a contact whose ``id2`` is a wall is flipped onto ``id1``.
  The contact point is ``i.geom.contactPoint``.
* periodic cells (``O.periodic``): the box is ``[0, diag(hSize))``, periodic on all three axes;
  positions and contact points are wrapped into it. Each particle pair's branch vector from Yade
  (``pos2 + cellDist * size - pos1``) must equal the minimum image that cgbound uses, else the
  cell is too small for the minimum-image convention and the frame is refused. Sheared cells are
  refused.
* the body force per unit mass is the NewtonIntegrator's gravity (a different ``body_force=`` is refused unless
  ``body_force_override=True``; when that gravity is 0, a given ``body_force=`` is used, with a warning).

Checks made on every frame (cheap, before the snapshot is returned):

* format and version of the file;
* force balance: Yade's per-body force ``O.forces.f(id)`` holds the contact forces only (the
  NewtonIntegrator adds gravity to the acceleration, not to the force container), so the contact
  forces of the frame summed on each particle, fixed ones included, must reproduce it, to
  ``tolerance`` (default 1e-9) times the RMS contact force. A mismatch names the file and the body;
  likely causes: the exporting PyRunner is not the last engine (forces and interactions from
  different steps), an engine adds forces (``O.forces.addF``, drag, buoyancy), or interactions that
  are not contacts. ``check_forces=False`` skips the check.
"""
from dataclasses import dataclass
import glob
import os
import re
import warnings

import numpy as np

from .._validate import flag
from ..box import Box
from ..snapshot import Contacts, Snapshot
from ._sequence import FrameReader
from .checks import force_balance
from .yade_export import FORMAT, VERSION

__all__ = ["YadeFrame", "YadeReader"]

DEFAULT_TOLERANCE = 1e-9


def _expand(paths):
    """File names from a directory, a glob pattern, one path or a list of these."""
    items = [paths] if isinstance(paths, (str, bytes, os.PathLike)) else list(paths)
    if not items:
        raise ValueError("paths: expected a directory, a pattern or a list of .npz files, got an empty list")
    out = []
    for item in items:
        item = os.fspath(item)
        if os.path.isdir(item):
            found = sorted(glob.glob(os.path.join(item, "*.npz")))
            if not found:
                raise FileNotFoundError(f"paths: no .npz files in the directory {item!r}")
            out.extend(found)
        elif glob.has_magic(item):
            found = sorted(glob.glob(item))
            if not found:
                raise FileNotFoundError(f"paths: the pattern {item!r} matches no file")
            out.extend(found)
        elif os.path.isfile(item):
            out.append(item)
        else:
            raise FileNotFoundError(f"paths: no such file {item!r}")
    return [os.path.abspath(p) for p in out]


def _arrays(path, names=None):
    """The arrays ``names`` (all if None) of a checked export, read now, so that a damaged member is an error
    naming the file (NumPy reads .npz members lazily and raises zipfile's errors at first access)."""
    with _load(path) as data:
        try:
            return {k: data[k] for k in (data.files if names is None else names)}
        except KeyError as exc:
            raise ValueError(f"{path}: the export has no array {exc}; write it again with the yade_export.py "
                             f"shipped with this cgbound") from None
        except Exception as exc:   # zipfile.BadZipFile, zlib.error, EOFError, ValueError from a damaged member
            raise ValueError(f"{path}: a damaged export ({type(exc).__name__}: {exc}); write the frame "
                             f"again") from None


def _load(path):
    try:
        data = np.load(path, allow_pickle=False)
        fmt = str(data["format"]) if "format" in data.files else None
        version = int(data["version"]) if "version" in data.files else None
    except Exception as exc:
        raise ValueError(f"{path}: not a cgbound Yade export (.npz written by yade_export.export_frame): {exc}") from None
    if fmt != FORMAT:
        raise ValueError(f"{path}: expected format {FORMAT!r} (written by yade_export.export_frame), got {fmt!r}")
    if version != VERSION:
        raise ValueError(f"{path}: expected format version {VERSION}, got {version}; use the yade_export.py "
                         "shipped with this cgbound")
    return data


@dataclass
class YadeFrame:
    """One Yade frame: ``snapshot``, ``ids`` (Yade body id of each particle), ``forces`` ((N, 3)
    ``O.forces.f`` of each particle: contact forces only), ``clump_id`` (N,; -1 when not in a
    clump), ``iter``, ``path``, ``contact_ids`` ((M, 2) Yade ids ``(id of i, id of j)``; the wall's
    id for wall contacts)."""

    snapshot: Snapshot
    ids: np.ndarray
    forces: np.ndarray
    clump_id: np.ndarray
    iter: int
    path: str
    contact_ids: np.ndarray

    def force_balance(self):
        """Per-particle mismatch between the summed contact forces and Yade's ``O.forces.f``.

        Returns a dict: ``mismatch`` ((N,) norms), ``scale`` (RMS contact-force magnitude, or RMS
        of Yade's forces without contacts) and ``relative`` (max mismatch / scale)."""
        snap = self.snapshot
        c = snap.contacts
        total = np.zeros((snap.n_particles, 3))
        if len(c):
            np.add.at(total, c.i, c.force)
            pair = c.j >= 0
            np.add.at(total, c.j[pair], -c.force[pair])
        return force_balance(total, self.forces, c.force)


class YadeReader(FrameReader):
    """Lazy sequence of :class:`cgbound.Snapshot` from Yade exports (see the module docstring).

    Parameters
    ----------
    paths : path, pattern or list of paths
        A directory (its ``*.npz``), a glob pattern, a file, or a list of these.
    check_forces : bool
        Check every frame's force balance (default True).
    tolerance : float
        Largest accepted force mismatch relative to the RMS contact force (default 1e-9).
    fixed_ids : sequence of int
        Yade body ids to treat as boundary in addition to the non-dynamic / blocked ones.
    body_force : (3,) array, optional
        The body force per unit mass when the export has no NewtonIntegrator gravity; when it has one, they must
        agree (to 1e-4 of the larger), unless it is 0 (weight from another engine or addF: the given one is used,
        with a warning).
    body_force_override : bool
        Use ``body_force`` even where it contradicts the NewtonIntegrator's nonzero gravity (a body force changed
        during the run, or applied by another engine). Default False: refused.
    """

    def __init__(self, paths, *, check_forces=True, tolerance=DEFAULT_TOLERANCE, fixed_ids=(), body_force=None,
                 units=None, body_force_override=False):
        self.units = units
        files = _expand(paths)
        if not (isinstance(tolerance, (int, float)) and not isinstance(tolerance, bool) and tolerance > 0):
            raise ValueError(f"tolerance: expected a positive number, got {tolerance!r}")
        self.check_forces = bool(check_forces)
        self.tolerance = float(tolerance)
        self.fixed_ids = np.unique(np.asarray(list(fixed_ids), dtype=np.int64))
        if body_force is not None:
            body_force = np.asarray(body_force, dtype=float)
            if body_force.shape != (3,) or not np.all(np.isfinite(body_force)):
                raise ValueError(f"body_force: expected 3 finite values, got {body_force.tolist()}")
        self.body_force = body_force
        self.body_force_override = flag(body_force_override, "body_force_override")
        if self.body_force_override and body_force is None:
            raise ValueError("body_force_override: True needs body_force= (--gravity), the body force to use")
        self._warned_zero_gravity = False
        frames = []
        for path in files:
            frames.append((int(_arrays(path, ("iter",))["iter"]), path))
        frames.sort()
        steps = [k for k, _ in frames]
        if len(set(steps)) != len(steps):
            dup = next(k for k in steps if steps.count(k) > 1)
            raise ValueError(f"paths: two files hold iteration {dup}: "
                             f"{[p for k, p in frames if k == dup]}")
        self._frames = [(p,) for _, p in frames]
        self._cache = None

    @property
    def iterations(self):
        return [self._load_iter(p) for (p,) in self._frames]

    @staticmethod
    def _load_iter(path):
        return int(_arrays(path, ("iter",))["iter"])

    def force_mismatch(self, index):
        """Max ``|summed contact forces - O.forces.f|`` over particles relative to the RMS contact force."""
        return self.frame(index).force_balance()["relative"]

    def _describe(self):
        return [], []

    # ------------------------------------------------------------------------------------------
    def _build(self, path):
        data = _arrays(path)
        ids, shape = data["id"], data["shape"]
        dynamic, blocked, clump = data["dynamic"], data["blocked"], data["clump_id"]
        sphere = shape == "Sphere"
        is_clump = shape == "Clump"
        wall = ~sphere & ~is_clump
        by_id = {int(b): k for k, b in enumerate(ids)}

        def translation_blocked(k):
            return sum(ch in str(blocked[k]) for ch in "xyz")

        # flags of a clump member come from its clump
        owner = np.array([by_id.get(int(c), k) if c >= 0 else k for k, c in enumerate(clump)])
        n_blocked = np.array([translation_blocked(int(o)) for o in owner], dtype=int)
        partly = sphere & dynamic[owner] & (n_blocked > 0) & (n_blocked < 3)
        if np.any(partly):
            k = int(np.flatnonzero(partly)[0])
            raise ValueError(f"{path}: body {ids[k]} has blockedDOFs {str(blocked[owner[k]])!r}: partly blocked "
                             "translation is neither flowing nor boundary; block x, y and z, or make it "
                             "non-dynamic, or unblock it")
        moving_wall = wall & dynamic & (np.array([translation_blocked(k) for k in range(len(ids))]) < 3)
        if np.any(moving_wall):
            k = int(np.flatnonzero(moving_wall)[0])
            raise ValueError(f"{path}: body {ids[k]} is a dynamic {shape[k]}: only spheres can be particles; "
                             "make the body non-dynamic (fixed=True) to use it as a wall")
        unknown = self.fixed_ids[~np.isin(self.fixed_ids, ids[sphere])]
        if unknown.size:   # a typo would leave the particle it meant flowing, silently
            what = "is not a sphere" if unknown.size == 1 else "are not spheres"
            raise ValueError(f"fixed_ids: {unknown[:5].tolist()} {what} of the frame {path} (its spheres' ids: "
                             f"{self._id_ranges(ids[sphere])}); check the ids")
        fixed_all = ~dynamic[owner] | (n_blocked == 3) | np.isin(ids, self.fixed_ids)
        part = np.flatnonzero(sphere)
        index_of = np.full(int(ids.max()) + 1 if ids.size else 1, -1, np.int64)
        index_of[ids[part]] = np.arange(part.size)
        wall_id = np.zeros(index_of.shape, bool)
        wall_id[ids[wall]] = True

        pos = data["pos"][part]
        periodic = bool(data["periodic"])
        if periodic:
            h = data["cell_hsize"]
            if np.any(h != np.diag(np.diag(h))):
                raise ValueError(f"{path}: the periodic cell is sheared (hSize {h.tolist()}); only orthogonal cells "
                                 "are supported")
            lengths = np.diag(h).copy()
            box = Box(np.zeros(3), lengths, periodic=True)
        else:
            r = data["radius"][part]
            pts = [pos - r[:, None], pos + r[:, None]]
            if data["contact_point"].size:
                pts.append(data["contact_point"])
            allpts = np.concatenate(pts)
            lo, hi = allpts.min(axis=0), allpts.max(axis=0)
            pad = np.maximum(hi - lo, 1.0) * 1e-9
            box = Box(lo - pad, hi + pad)

        id1, id2 = data["id1"], data["id2"]
        force = data["normal_force"] + data["shear_force"]   # on id2 from id1
        point = data["contact_point"]
        known = (id1 < index_of.size) & (id2 < index_of.size)
        if not np.all(known):
            k = int(np.flatnonzero(~known)[0])
            raise ValueError(f"{path}: interaction ({id1[k]}, {id2[k]}) names a body that is not in the frame")
        p1, p2 = index_of[id1], index_of[id2]
        w1, w2 = wall_id[id1], wall_id[id2]
        bad = ((p1 < 0) & ~w1) | ((p2 < 0) & ~w2) | (w1 & w2)
        if np.any(bad):
            k = int(np.flatnonzero(bad)[0])
            raise ValueError(f"{path}: interaction ({id1[k]}, {id2[k]}) is not between a sphere and a sphere or "
                             "a wall body; cgbound cannot place it")
        flip = w2      # the particle is id1: the force on it is the opposite
        ci = np.where(flip, p1, p2)
        cj = np.where(flip, -1, np.where(w1, -1, p1))
        cf = np.where(flip[:, None], -force, force)
        contact_ids = np.stack([np.where(flip, id1, id2), np.where(flip, id2, id1)], axis=1)

        cell_dist = data["cell_dist"]
        if not periodic and np.any(cell_dist != 0):
            raise ValueError(f"{path}: non-periodic frame with non-zero cellDist")
        if periodic:
            pair = (p1 >= 0) & (p2 >= 0)
            # cgbound's branch of contact (i = id2, j = id1) is r_id2 - r_id1 (minimum image)
            yade_branch = (pos[p2[pair]] + cell_dist[pair] * lengths) - pos[p1[pair]]
            raw = pos[p2[pair]] - pos[p1[pair]]
            minimum = raw - lengths * np.round(raw / lengths)
            off = np.linalg.norm(minimum - yade_branch, axis=1) > 1e-9 * float(lengths.max())
            if np.any(off):
                k = int(np.flatnonzero(pair)[np.flatnonzero(off)[0]])
                raise ValueError(f"{path}: bodies {id1[k]} and {id2[k]} touch across the periodic cell at a "
                                 "distance that is not the minimum image (the cell is smaller than twice the "
                                 "contact distance); cgbound's branch vectors would be wrong")
            pos = pos - lengths * np.floor(pos / lengths)
            point = point - lengths * np.floor(point / lengths)
        masses = data["mass"][part].copy()
        member = clump[part] >= 0
        if member.any():
            # a clump's mass can differ from the sum of its members' (Yade integrates overlapping clumps);
            # members share the clump's mass in proportion to their own, so density and momentum are the clump's
            for c in np.unique(clump[part][member]):
                rows = clump[part] == c
                masses[rows] *= data["mass"][by_id[int(c)]] / masses[rows].sum()
        g = self.body_force
        stored = data["gravity"]
        if np.all(np.isfinite(stored)) and not (self.body_force_override and g is not None):
            if g is None:
                g = stored
            elif not np.any(stored):
                # weight from another engine or addF: O.forces.f, which the force check uses, holds it not either
                if not self._warned_zero_gravity:
                    self._warned_zero_gravity = True
                    warnings.warn(f"{path}: the run's gravity (the NewtonIntegrator's) is 0; the given body force "
                                  f"{g.tolist()} is used (weight from another engine or addF)", stacklevel=4)
            elif float(np.max(np.abs(g - stored))) > 1e-4 * max(float(np.max(np.abs(g))),
                                                                float(np.max(np.abs(stored)))):
                # the NewtonIntegrator's gravity is the one the particles fell under: another would unbalance every
                # momentum balance, silently (O.forces.f, which the force check uses, holds no gravity)
                raise ValueError(f"body_force: {g.tolist()} is not the gravity of the run, {stored.tolist()} (the "
                                 f"NewtonIntegrator's, in {path}); leave it out to use the export's, or, if the run's "
                                 f"body force really differs from it (changed during the run, another engine), pass "
                                 f"body_force_override=True (--gravity-override)")
            else:
                g = stored
        try:
            snapshot = Snapshot(pos, data["vel"][part], masses, box=box,
                                contacts=Contacts(ci, cj, cf, point), fixed=fixed_all[part], body_force=g,
                                radii=data["radius"][part], time=float(data["time"]))
        except (ValueError, TypeError, IndexError) as exc:   # a value of the export refused: name the file, the body
            row = re.search(r"at index \(?(\d+)", str(exc))
            body = f" (index {row.group(1)} is Yade body {ids[part][int(row.group(1))]})" if row and \
                int(row.group(1)) < part.size else ""
            raise ValueError(f"{path}: {exc}{body}") from None
        result = YadeFrame(snapshot, ids[part], data["force"][part], clump[part], int(data["iter"]), path,
                           contact_ids)
        if self.check_forces:
            balance = result.force_balance()
            if balance["relative"] > self.tolerance:
                k = int(np.argmax(balance["mismatch"]))
                raise ValueError(
                    f"{path}: body {ids[part][k]}: its contact forces sum to {self._sum(result, k)} but Yade's "
                    f"O.forces.f gives {data['force'][part][k].tolist()} (mismatch {balance['relative']:.3g} of the "
                    f"RMS contact force, tolerance {self.tolerance:g}). Likely causes: the PyRunner calling "
                    "export_frame is not the last engine (forces and interactions from different steps), an engine "
                    "adds forces (O.forces.addF, drag, buoyancy), or non-contact interactions. Fix: make the "
                    "PyRunner the last engine, or pass check_forces=False if you know why")
        return result

    @staticmethod
    def _id_ranges(ids):
        """Sorted ids as 'a..b, c' runs (at most 4 runs shown)."""
        ids = np.unique(ids)
        if not ids.size:
            return "none"
        cut = np.flatnonzero(np.diff(ids) != 1) + 1
        runs = [f"{r[0]}..{r[-1]}" if r.size > 1 else f"{r[0]}" for r in np.split(ids, cut)]
        return ", ".join(runs[:4]) + (", ..." if len(runs) > 4 else "")

    @staticmethod
    def _sum(frame, k):
        c = frame.snapshot.contacts
        total = c.force[c.i == k].sum(axis=0) - c.force[c.j == k].sum(axis=0)
        return total.tolist()
