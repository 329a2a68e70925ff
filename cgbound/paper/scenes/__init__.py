"""Scenes: declarative discrete-particle simulations run with a real DEM engine (LAMMPS).

A :class:`Scene` lists particles, boundaries and the effects it needs; :func:`run_scene`
writes LAMMPS input containing exactly those effects, runs ``lmp`` and reads back thermo
output and snapshots with consistent per-contact forces (dumped inside ``run 0``).
The paper's scenes are :func:`boundary_2d` (Fig. 1) and :func:`chute` (Figs. 2-3); :func:`silo` is a
static column in a cylindrical silo (the Janssen effect); :func:`inclined_chute` is the chute sized for
mu(I) at several inclinations (notebook 05).
"""
from .inclined import RHEOLOGY_CONTACT_MODEL, RHEOLOGY_TIMESTEP, inclined_chute
from .lammps import Frames, MoveWall, Run, Settle, Trace, data_file, input_script
from .paper import binary_collision, boundary_2d, chute, measure_collision
from .runner import LammpsError, SceneRun, find_lammps, run_scene
from .scene import PAPER_COLLISION_TIME, PAPER_CONTACT_MODEL, PAPER_TIMESTEP, ContactModel, CylinderWall, Scene, Wall
from .silo import SILO_CONTACT_MODEL, SILO_TIMESTEP, silo

__all__ = ["ContactModel", "CylinderWall", "Frames", "LammpsError", "PAPER_COLLISION_TIME", "PAPER_CONTACT_MODEL",
           "PAPER_TIMESTEP",
           "Run", "Scene", "SceneRun", "Settle", "Trace", "Wall", "binary_collision", "boundary_2d", "chute",
           "data_file", "find_lammps", "input_script", "measure_collision", "run_scene",
           "MoveWall", "SILO_CONTACT_MODEL", "SILO_TIMESTEP", "silo",
           "RHEOLOGY_CONTACT_MODEL", "RHEOLOGY_TIMESTEP", "inclined_chute"]
