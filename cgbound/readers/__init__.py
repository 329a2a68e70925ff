"""Readers: each yields cg.Snapshot objects lazily, with len() and slicing where the format allows
(docs/theory.md, "The snapshot model")."""
from .hdf5 import HDF5Snapshots, write_snapshots
from .lammps import LammpsFrame, LammpsReader, pair_local_columns
from .liggghts import LiggghtsReader, pair_gran_local_columns
from .mdanalysis import MDAnalysisReader
from .mercury import MercuryFrame, MercuryReader, write_mercury

__all__ = ["HDF5Snapshots", "LammpsFrame", "LammpsReader", "LiggghtsReader", "MDAnalysisReader", "MercuryFrame",
           "MercuryReader", "open_dataset", "pair_gran_local_columns", "pair_local_columns", "write_mercury",
           "write_snapshots"]


def open_dataset(path, format=None, **options):
    """Open a dataset as a lazy sequence of Snapshots; ``format`` defaults from the extension.

    ``.data`` files are MercuryDPM (``fstat_path=`` and ``density=`` as keywords).
    ``format="lammps"`` takes the particle dump as ``path`` and the reader's options
    (e.g. ``pairs=`` the contact dump, ``fixed_types=``) as keywords.
    """
    import os
    fmt = format or {".h5": "hdf5", ".hdf5": "hdf5", ".data": "mercury"}.get(os.path.splitext(str(path))[1].lower())
    if fmt == "hdf5":
        return HDF5Snapshots(path, **options)
    if fmt == "lammps":
        return LammpsReader(path, **options)
    if fmt == "mercury":
        return MercuryReader(path, **options)
    if fmt == "liggghts":
        return LiggghtsReader(path, **options)
    if fmt == "mdanalysis":
        return MDAnalysisReader(path, **options)
    raise ValueError(f"format: cannot tell the format of {str(path)!r}; expected one of: hdf5, lammps, liggghts, mdanalysis, mercury")
