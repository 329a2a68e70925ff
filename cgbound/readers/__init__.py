"""Readers: each yields cg.Snapshot objects lazily, with len() and slicing where the format allows."""
from .hdf5 import HDF5Snapshots, write_snapshots

__all__ = ["HDF5Snapshots", "open_dataset", "write_snapshots"]


def open_dataset(path, format=None, **options):
    """Open a dataset as a lazy sequence of Snapshots; ``format`` defaults from the extension."""
    import os
    fmt = format or {".h5": "hdf5", ".hdf5": "hdf5"}.get(os.path.splitext(str(path))[1].lower())
    if fmt == "hdf5":
        return HDF5Snapshots(path, **options)
    raise ValueError(f"format: cannot tell the format of {str(path)!r}; expected one of: hdf5")
