"""Export Yade frames for cgbound: runs inside Yade's own Python, needs numpy only.

This file imports nothing from cgbound, so it can be used without installing cgbound into
Yade's interpreter: copy it next to the Yade script, or ``exec`` it::

    exec(open("/path/to/cgbound/readers/yade_export.py").read())   # defines export_frame

    O.engines = [ForceResetter(), InsertionSortCollider([...]), InteractionLoop([...], [...], [...]),
                 NewtonIntegrator(gravity=(0, 0, -9.81), damping=0.0),
                 PyRunner(command='export_frame("frames")', iterPeriod=1000)]

Put the PyRunner LAST in ``O.engines``: then the per-body forces ``O.forces.f(id)`` and the
interaction forces both come from the same step's InteractionLoop, and the reader can check that
they balance. ``export_frame`` may also be called after ``O.run(n, True)`` returns.

One ``.npz`` file per frame (``<dir>/yade_<iter>.npz`` when given a directory), with
``format = "cgbound-yade"`` and ``version = 1``. Arrays (B bodies, I real interactions):

- ``time``, ``iter``, ``dt``: scalars (``O.time``, ``O.iter``, ``O.dt``)
- ``id`` (B,), ``shape`` (B,) str (``Sphere``, ``Facet``, ``Wall``, ``Box``, ``Clump``: clump
  bodies have no shape; ``None`` for none), ``pos``, ``vel``, ``force`` (B, 3) (``O.forces.f``:
  contact forces only; Yade's NewtonIntegrator adds gravity to the acceleration, not to the force
  container), ``mass`` (B,), ``radius`` (B,) (NaN for non-spheres), ``dynamic`` (B,) bool,
  ``blocked`` (B,) str (``b.state.blockedDOFs``), ``clump_id`` (B,) (-1 when not a clump member)
- ``id1``, ``id2`` (I,), ``normal_force``, ``shear_force`` (I, 3) (Yade applies
  ``normal_force + shear_force`` ON ``id2`` FROM ``id1``, and the opposite on ``id1``),
  ``contact_point``, ``normal`` (I, 3), ``cell_dist`` (I, 3) int (``i.cellDist``: the periodic
  image of ``id2`` in contact with ``id1``)
- ``periodic`` bool, ``cell_hsize`` (3, 3) (``O.cell.hSize``; zeros when not periodic),
  ``gravity`` (3,) (the first NewtonIntegrator's gravity; NaN when there is no NewtonIntegrator)
"""
import os

import numpy

FORMAT = "cgbound-yade"
VERSION = 1

__all__ = ["export_frame", "FORMAT", "VERSION"]


def _vec(v):
    return [float(v[0]), float(v[1]), float(v[2])]


def _yade_globals():
    """``O`` and the engine classes from Yade's namespace (this module may be exec'd or imported)."""
    try:
        import yade
        return yade.O, yade.NewtonIntegrator
    except (ImportError, AttributeError):  # pragma: no cover - exec'd inside Yade's globals
        return globals()["O"], globals()["NewtonIntegrator"]


def export_frame(path_or_dir, O=None, compressed=True):
    """Write the current Yade state to one ``.npz`` file; returns the path written.

    ``path_or_dir``: a file name ending in ``.npz``, or a directory (created if needed) in
    which the file is called ``yade_<O.iter>.npz`` (zero-padded to 10 digits so names sort).
    """
    newton_class = None
    if O is None:
        O, newton_class = _yade_globals()
    path = os.fspath(path_or_dir)
    if not path.endswith(".npz"):
        os.makedirs(path, exist_ok=True)
        path = os.path.join(path, "yade_%010d.npz" % O.iter)

    ids, shapes, pos, vel, force, mass, radius, dynamic, blocked, clump = ([] for _ in range(10))
    for b in O.bodies:
        if b is None:  # erased body
            continue
        ids.append(b.id)
        if b.isClump:
            shapes.append("Clump")
        else:
            shapes.append("None" if b.shape is None else type(b.shape).__name__)
        r = getattr(b.shape, "radius", None) if b.shape is not None else None
        radius.append(float("nan") if r is None or shapes[-1] != "Sphere" else float(r))
        pos.append(_vec(b.state.pos))
        vel.append(_vec(b.state.vel))
        force.append(_vec(O.forces.f(b.id)))
        mass.append(float(b.state.mass))
        dynamic.append(bool(b.dynamic))
        blocked.append(str(b.state.blockedDOFs))
        clump.append(int(b.clumpId) if b.isClumpMember else -1)

    id1, id2, fn, fs, cp, nrm, cd = ([] for _ in range(7))
    for i in O.interactions:
        if not i.isReal:
            continue
        phys, geom = i.phys, i.geom
        if not (hasattr(phys, "normalForce") and hasattr(phys, "shearForce") and hasattr(geom, "contactPoint")):
            raise TypeError("export_frame: interaction (%d, %d) has %s/%s without normalForce, shearForce or "
                            "contactPoint" % (i.id1, i.id2, type(geom).__name__, type(phys).__name__))
        id1.append(i.id1)
        id2.append(i.id2)
        fn.append(_vec(phys.normalForce))
        fs.append(_vec(phys.shearForce))
        cp.append(_vec(geom.contactPoint))
        nrm.append(_vec(geom.normal) if hasattr(geom, "normal") else [float("nan")] * 3)
        c = i.cellDist
        cd.append([int(c[0]), int(c[1]), int(c[2])])

    gravity = [float("nan")] * 3
    for e in O.engines:
        if type(e).__name__ == "NewtonIntegrator" or (newton_class is not None and isinstance(e, newton_class)):
            gravity = _vec(e.gravity)
            break
    periodic = bool(O.periodic)
    hsize = [[float(O.cell.hSize[r][c]) for c in range(3)] for r in range(3)] if periodic else [[0.0] * 3] * 3

    def arr3(rows, dtype=float):
        return numpy.array(rows, dtype=dtype).reshape(-1, 3)

    data = dict(format=numpy.array(FORMAT), version=numpy.array(VERSION), time=numpy.array(float(O.time)),
                iter=numpy.array(int(O.iter)), dt=numpy.array(float(O.dt)),
                id=numpy.array(ids, dtype=numpy.int64), shape=numpy.array(shapes, dtype=str),
                pos=arr3(pos), vel=arr3(vel), force=arr3(force), mass=numpy.array(mass, dtype=float),
                radius=numpy.array(radius, dtype=float), dynamic=numpy.array(dynamic, dtype=bool),
                blocked=numpy.array(blocked, dtype=str), clump_id=numpy.array(clump, dtype=numpy.int64),
                id1=numpy.array(id1, dtype=numpy.int64), id2=numpy.array(id2, dtype=numpy.int64),
                normal_force=arr3(fn), shear_force=arr3(fs), contact_point=arr3(cp), normal=arr3(nrm),
                cell_dist=arr3(cd, numpy.int64), periodic=numpy.array(periodic),
                cell_hsize=numpy.array(hsize, dtype=float), gravity=numpy.array(gravity, dtype=float))
    tmp = path + ".part"
    with open(tmp, "wb") as fh:
        (numpy.savez_compressed if compressed else numpy.savez)(fh, **data)
    os.replace(tmp, path)
    return path
