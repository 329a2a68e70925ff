"""Readers: each yields cg.Snapshot objects lazily, with len() and slicing where the format allows
(docs/theory.md, "The snapshot model")."""
from .dataset import open_dataset
from .files import CompanionFileWarning
from .hdf5 import HDF5Snapshots, write_snapshots
from .lammps import LammpsFrame, LammpsReader, pair_local_columns
from .lammps_input import InputScript, InputScriptError, read_input
from .liggghts import LiggghtsReader, pair_gran_local_columns
from .mdanalysis import MDAnalysisReader
from .mercury import MercuryFrame, MercuryReader, write_mercury
from .yade import YadeReader

__all__ = ["CompanionFileWarning", "HDF5Snapshots", "InputScript", "InputScriptError", "LammpsFrame", "LammpsReader", "LiggghtsReader",
           "MDAnalysisReader", "MercuryFrame", "MercuryReader", "YadeReader", "open_dataset",
           "pair_gran_local_columns", "pair_local_columns", "read_input", "write_mercury", "write_snapshots"]
