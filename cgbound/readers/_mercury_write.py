"""Write snapshots as MercuryDPM ``.data`` and ``.fstat`` files (the layouts of cgbound/readers/mercury.py)."""
import os

import numpy as np

from .._atomic import atomic_write
from .checks import repeated_pairs

__all__ = ["write_mercury"]


def write_mercury(snapshots, data_path, fstat_path, *, precision=17, wall_index=None):
    """Write snapshots as MercuryDPM ``.data`` and ``.fstat`` files (the layouts of the module docstring
    of :mod:`cgbound.readers.mercury`).

    Radii are required. Pairs of flowing particles are written twice (as ``writeToFStat`` does),
    pairs with a fixed particle once from the flowing side, walls once with the flipped normal
    and tangent of ``writeToFStat``. Orientation, angular velocity and the tangential overlap are
    written as 0. ``wall_index`` (callable(snapshot) -> (M,) ints, optional) gives the MercuryDPM
    wall index of each wall contact (default 0). Returns the number of frames written.
    """
    count = 0
    fmt = f"%.{int(precision)}g"
    if os.path.abspath(os.fspath(data_path)) == os.path.abspath(os.fspath(fstat_path)):
        raise ValueError(f"fstat_path: the same file as data_path ({os.fspath(data_path)!r}); expected two files")

    def vec(v):
        return " ".join(fmt % x for x in v)

    def write(data_tmp, fstat_tmp):
        nonlocal count
        with open(data_tmp, "w") as fd, open(fstat_tmp, "w") as ff:
            for snap in snapshots:
                if snap.radii is None:
                    raise ValueError("write_mercury: snapshots need radii")
                _refuse_repeated_pairs(snap)
                _write_data_frame(fd, snap, fmt, vec)
                widx = np.zeros(len(snap.contacts), np.int64) if wall_index is None else np.asarray(wall_index(snap))
                _write_fstat_frame(ff, snap, widx, fmt, vec)
                count += 1

    # both files through temporaries renamed into place once every frame is written: a failure half way (a
    # snapshot without radii) left existing files truncated and half-written ones behind
    atomic_write(data_path, lambda data_tmp: atomic_write(fstat_path, lambda fstat_tmp: write(data_tmp, fstat_tmp)))
    return count


def _write_data_frame(fd, snap, fmt, vec):
    dim, n = snap.dim, snap.n_particles
    vel = snap.velocities if snap.velocities is not None else np.zeros((n, dim))
    species = snap.species if snap.species is not None else np.zeros(n, np.int64)
    fd.write(f"{n} {fmt % snap.time} {vec(snap.box.lower)} {vec(snap.box.upper)}\n")
    for k in range(n):
        if dim == 3:
            fd.write(f"{vec(snap.positions[k])} {vec(vel[k])} {fmt % snap.radii[k]} 0 0 0 0 0 0 {species[k]}\n")
        else:
            fd.write(f"{vec(snap.positions[k])} {vec(vel[k])} {fmt % snap.radii[k]} 0 0 {species[k]}\n")


def _refuse_repeated_pairs(snap):
    """A pair listed once per periodic image (``Contacts.branch``: a box thinner than two contact distances) has no
    MercuryDPM form that its reader takes back (a pair once from each side at most, the minimum image): refused."""
    c = snap.contacts
    if c.branch is None:
        return
    pair = c.j >= 0
    if repeated_pairs(c.i[pair], c.j[pair], snap.n_particles) is not None:
        raise ValueError(f"write_mercury: the snapshot at time {snap.time:g} lists a pair once per periodic image "
                         f"(contacts.branch: a box thinner than two contact distances), which MercuryDPM's .fstat "
                         f"cannot hold (a pair once, the minimum image). Write it with write_snapshots (HDF5), "
                         f"which keeps the branches")


def _write_fstat_frame(ff, snap, widx, fmt, vec):
    dim = snap.dim
    lo3 = list(snap.box.lower) + [0.0] * (3 - dim)
    hi3 = list(snap.box.upper) + [0.0] * (3 - dim)
    ff.write(f"# {fmt % snap.time} 1\n# {vec(lo3)} {vec(hi3)}\n")
    ff.write(f"# {fmt % float(np.min(snap.radii))} {fmt % float(np.max(snap.radii))} 0 0 0 0\n")
    c = snap.contacts
    wall = c.j < 0
    # x_i - c for walls, x_i - x_j for pairs (minimum image)
    partner = np.where(wall[:, None], c.point, snap.positions[np.where(wall, 0, c.j)])
    arms = snap.box.minimum_image(snap.positions[c.i] - partner)
    if c.branch is not None:    # (a pair listed once per periodic image: its own branch)
        arms = np.where(wall[:, None], arms, c.branch)
    for k in range(len(c)):
        i, j, f, p, arm = int(c.i[k]), int(c.j[k]), c.force[k], c.point[k], arms[k]
        if j < 0:
            if snap.fixed[i]:
                continue
            nrm = arm / np.linalg.norm(arm)       # from the wall to the particle
            delta = 2.0 * (snap.radii[i] - np.linalg.norm(arm))
            ff.write(_fstat_line(fmt, vec, snap.time, i, -1 - int(widx[k]), p, nrm, f, delta, dim, wall=True))
            continue
        nrm = arm / np.linalg.norm(arm)           # from j to i
        delta = snap.radii[i] + snap.radii[j] - np.linalg.norm(arm)
        if not snap.fixed[i]:
            ff.write(_fstat_line(fmt, vec, snap.time, i, j, p, nrm, f, delta, dim))
        if not snap.fixed[j]:
            ff.write(_fstat_line(fmt, vec, snap.time, j, i, p, -nrm, -f, delta, dim))


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
