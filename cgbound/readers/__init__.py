"""Readers: each yields cg.Snapshot objects lazily, with len() and slicing where the format allows
(DESIGN.md section 1)."""
from .dataset import open_dataset
from .hdf5 import HDF5Snapshots, write_snapshots
from .lammps import LammpsFrame, LammpsReader, pair_local_columns
from .liggghts import LiggghtsReader, pair_gran_local_columns
from .mdanalysis import MDAnalysisReader
from .mercury import MercuryFrame, MercuryReader, write_mercury

__all__ = ["HDF5Snapshots", "LammpsFrame", "LammpsReader", "LiggghtsReader", "MDAnalysisReader", "MercuryFrame",
           "MercuryReader", "open_dataset", "pair_gran_local_columns", "pair_local_columns", "write_mercury",
           "write_snapshots"]
