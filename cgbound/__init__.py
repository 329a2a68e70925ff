"""cgbound: boundary-aware coarse graining of discrete-particle data.

Goldhirsch's coarse graining extended to boundaries by Weinhart, Thornton,
Luding and Bokhove (2012), with a C core. Stresses follow the paper's
tension-positive sign unless ``convention="compression"`` is asked for.
"""
from . import readers
from ._engine import have_openmp
from .block_errors import CorrelatedBlocksWarning
from .box import Box
from .coarse import CoarseGrain, coarse_grain
from .cylindrical import CylindricalGrid
from .cylindrical_balance import CylindricalMomentumBalance, cylindrical_momentum_balance_residual
from .fields import FIELDS
from .grid import Grid, Points
from .kernels import Gaussian, Heaviside, Lucy
from .residual import MomentumBalance, momentum_balance_residual
from .result import Result
from .scale_separation import WidthScan, width_scan
from .rheology import MuOfIFit, fit_mu_of_i, mu_of_i, stress_ratio
from .snapshot import Contacts, Snapshot
from ._threads import get_num_threads, set_num_threads, threads
from .tiled import coarse_grain_tiled
from .truncation import gaussian_cutoff_for, gaussian_tail_fraction
from .units import Units
from .rotation import ROTATION_FIELDS, rotation_fields
from .angular_balance import AngularMomentumBalance, angular_momentum_balance_residual

from ._version import __version__

FIELD_NAMES = tuple(FIELDS)

__all__ = ["Box", "CoarseGrain", "Contacts", "FIELD_NAMES", "Gaussian", "Grid", "Heaviside", "Lucy",
           "MomentumBalance", "Points", "Result", "Snapshot", "coarse_grain", "momentum_balance_residual",
           "have_openmp", "get_num_threads", "set_num_threads", "threads", "coarse_grain_tiled",
           "gaussian_cutoff_for", "gaussian_tail_fraction", "CorrelatedBlocksWarning",
           "WidthScan", "width_scan", "Units", "stress_ratio",
           "ROTATION_FIELDS", "rotation_fields", "AngularMomentumBalance", "angular_momentum_balance_residual",
           "MuOfIFit", "fit_mu_of_i", "mu_of_i", "CylindricalGrid",
           "CylindricalMomentumBalance", "cylindrical_momentum_balance_residual"]
