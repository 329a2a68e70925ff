"""Readers: each yields cg.Snapshot objects lazily, with len() and slicing where the format allows."""
from .hdf5 import HDF5Snapshots, write_snapshots

__all__ = ["HDF5Snapshots", "write_snapshots"]
