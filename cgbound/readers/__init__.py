"""Readers: convert simulation output to :class:`cgbound.Snapshot` sequences (DESIGN.md section 1)."""
from .lammps import LammpsFrame, LammpsReader, pair_local_columns

__all__ = ["LammpsFrame", "LammpsReader", "pair_local_columns"]
