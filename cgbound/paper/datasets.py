"""Datasets shipped with cgbound (made with LAMMPS by the scripts in ``scripts/``).

* :func:`chute_steady`: the paper's steady chute flow (Figs. 2-3), frames in t = [2000, 2100].
* :func:`chute_kinetic_energy`: the chute's kinetic energy from t = 0 (shows the window is steady).
* :func:`chute_dense_profiles`: Fig. 3 profiles of the chute sampled as in the paper (every t_c / 2).
* :func:`boundary_2d`: the paper's Fig. 1 configuration, relaxed until static.
* :func:`rheology_chutes`: depth profiles of steady chute flows at several inclinations, for mu(I) (notebook 05).

All of them are in the paper's units (flowing particle diameter d = 1, mass m = 1, gravity g = 1: the
``"mercury"`` system of :mod:`cgbound.units`), and say so (``units``).
"""
import os

import numpy as np

from ..units import as_units

#: the paper's scenes: d = m = g = 1 (cgbound.paper.scenes)
PAPER_UNITS = "mercury"

DATA_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "data")


def path(name):
    """Absolute path of a shipped data file."""
    full = os.path.join(DATA_DIR, name)
    if not os.path.exists(full):
        raise FileNotFoundError(f"name: no shipped dataset {name!r} in {DATA_DIR}")
    return full


def chute_steady():
    """The steady chute frames as a lazy :class:`cgbound.readers.HDF5Snapshots`."""
    from ..readers.hdf5 import HDF5Snapshots
    return HDF5Snapshots(path("chute_steady.h5"), units=PAPER_UNITS)


def chute_kinetic_energy():
    """(time, kinetic energy of the flowing particles) from the start of the chute run."""
    data = np.loadtxt(path("chute_kinetic_energy.csv"), delimiter=",")
    return data[:, 0], data[:, 1]


def chute_dense_profiles():
    """Fig. 3 profiles averaged over 4001 chute frames taken every t_c / 2 (a
    :class:`cgbound.paper.profiles.DepthProfiles`; made by scripts/check_chute_dense_sampling.py)."""
    from .profiles import DepthProfiles
    profiles = DepthProfiles.from_hdf5(path("chute_dense_profiles.h5"))
    profiles.units = as_units(PAPER_UNITS)
    return profiles


def boundary_2d():
    """The relaxed Fig. 1 scene (a :class:`cgbound.Snapshot`)."""
    from ..readers.hdf5 import HDF5Snapshots
    return HDF5Snapshots(path("boundary_2d.h5"), units=PAPER_UNITS)[0]


def rheology_chutes():
    """Depth profiles of the steady chutes at several inclinations (a list of
    :class:`cgbound.paper.chute_rheology.ChuteProfiles`, by angle; made by scripts/make_rheology_chutes.py)."""
    from .chute_rheology import read_profiles
    return read_profiles(path("rheology_chutes.h5"))
