"""A scene: particles, boundaries and the physical effects a simulation of them needs, nothing more.

A :class:`Scene` is declarative: it says *what* is simulated (particles, fixed boundary
particles, plane walls, gravity, the contact model, rotation, background damping, periodic
axes, 2D or 3D). :mod:`cgbound.paper.scenes.lammps` turns it into engine input that contains exactly
the effects listed in :attr:`Scene.effects`.
"""
from dataclasses import dataclass, field

import numpy as np

from ..._validate import real_array
from ...box import AXIS_NAMES, Box


@dataclass(frozen=True)
class ContactModel:
    """Linear spring-dashpot contacts, optionally with a tangential spring-dashpot capped by sliding friction.

    The normal force on a particle is ``kn * overlap - m_eff * gamma_n * v_n`` with
    ``m_eff = m_i m_j / (m_i + m_j)`` (``m_eff = m`` against fixed particles and walls):
    the damping constants are rates per unit effective mass, as in LAMMPS's ``gran/hooke``
    styles. Then the collision time and restitution depend on ``kn / m_eff`` and ``gamma_n``
    only (:meth:`collision_time`, :meth:`restitution`).

    Parameters
    ----------
    kn : float
        Normal spring constant.
    gamma_n : float
        Normal damping rate (per unit effective mass).
    kt : float or None
        Tangential spring constant; None means no tangential force at all.
    gamma_t : float
        Tangential damping rate (per unit effective mass); used only with ``kt``.
    friction : float
        Sliding (Coulomb) friction coefficient mu capping the tangential force; required (> 0) with ``kt``.
    """

    kn: float
    gamma_n: float = 0.0
    kt: float = None
    gamma_t: float = 0.0
    friction: float = 0.0

    def __post_init__(self):
        if not (np.isfinite(self.kn) and self.kn > 0):
            raise ValueError(f"kn: expected a positive spring constant, got {self.kn!r}")
        for name in ("gamma_n", "gamma_t", "friction"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"{name}: expected a non-negative number, got {value!r}")
        if self.kt is not None and not (np.isfinite(self.kt) and self.kt > 0):
            raise ValueError(f"kt: expected a positive spring constant or None, got {self.kt!r}")
        if self.kt is None and (self.gamma_t or self.friction):
            raise ValueError("kt: gamma_t and friction need a tangential spring constant kt")
        if self.kt is not None and self.friction <= 0:
            # LAMMPS caps the tangential force at friction * normal force: zero friction means none
            raise ValueError("friction: a tangential spring needs a positive sliding friction coefficient")

    @property
    def tangential(self):
        return self.kt is not None

    def _omega(self, m_eff):
        w2 = self.kn / m_eff - 0.25 * self.gamma_n ** 2
        if w2 <= 0:
            raise ValueError("gamma_n: overdamped contact (no bounce), collision time undefined")
        return np.sqrt(w2)

    def collision_time(self, m_eff=0.5):
        """Duration of a normal collision, pi / sqrt(kn / m_eff - gamma_n^2 / 4)."""
        return np.pi / self._omega(m_eff)

    def restitution(self, m_eff=0.5):
        """Normal coefficient of restitution, exp(-gamma_n t_c / 2)."""
        return float(np.exp(-0.5 * self.gamma_n * self.collision_time(m_eff)))


#: The paper's contact model (section 3.1) in units d = m = g = 1. Its damping constants are
#: consistent with t_c = 0.005 and e = 0.88 only as rates per unit effective mass (a plain
#: dashpot of 50 would give e = 0.78 for two unit masses): t_c = 0.00497, e = 0.883.
PAPER_CONTACT_MODEL = ContactModel(kn=2e5, gamma_n=50.0, kt=2.0 / 7.0 * 2e5, gamma_t=50.0, friction=0.5)
#: The paper's collision time t_c = 0.005 sqrt(d / g) and its time step t_c / 50.
PAPER_COLLISION_TIME = 0.005
PAPER_TIMESTEP = PAPER_COLLISION_TIME / 50.0


@dataclass(frozen=True)
class Wall:
    """A flat frictional wall normal to ``axis`` at ``position``; particles stay on the ``side`` given."""

    axis: str
    position: float
    side: str = "above"

    def __post_init__(self):
        if self.axis not in AXIS_NAMES:
            raise ValueError(f"axis: expected one of {AXIS_NAMES}, got {self.axis!r}")
        if self.side not in ("above", "below"):
            raise ValueError(f"side: expected 'above' or 'below', got {self.side!r}")
        if not np.isfinite(self.position):
            raise ValueError(f"position: expected a finite number, got {self.position!r}")


@dataclass(frozen=True)
class CylinderWall:
    """A frictional cylindrical wall (a 3D scene's side wall) of ``radius`` around an axis along ``axis``
    through ``center`` (the two other coordinates, in axis order); particles stay inside.

    The cylinder is unbounded along its axis (no end caps): close it with a :class:`Wall`.
    """

    axis: str
    center: tuple
    radius: float

    def __post_init__(self):
        if self.axis not in AXIS_NAMES:
            raise ValueError(f"axis: expected one of {AXIS_NAMES}, got {self.axis!r}")
        center = tuple(float(c) for c in np.ravel(self.center))
        if len(center) != 2 or not all(np.isfinite(center)):
            raise ValueError(f"center: expected two finite coordinates, got {self.center!r}")
        object.__setattr__(self, "center", center)
        if not (np.isfinite(self.radius) and self.radius > 0):
            raise ValueError(f"radius: expected a positive number, got {self.radius!r}")


@dataclass
class Scene:
    """Particles, boundaries and effects of a discrete-particle simulation.

    Parameters
    ----------
    name : str
    box : Box
        Simulation box; its periodic flags are the periodic axes. Non-periodic axes of a 3D
        scene grow with the particles (LAMMPS shrink-wrapping), their bounds are a hint.
    positions : (N, D) array
        D = 2 (axes x, z; gravity usually along -z) or 3.
    radii : (N,) array
    masses : (N,) array
        Masses used by the dynamics (fixed particles: any positive value, they do not move).
    fixed : (N,) bool array, optional
        Boundary particles: never integrated, infinite mass in contacts.
    velocities : (N, D) array, optional
        Initial velocities (default rest).
    contacts : ContactModel
    gravity : (D,) array or None
        Acceleration of gravity (body force per unit mass); None for no gravity.
    rotation : bool
        Integrate particle rotation (needed for rolling with tangential forces).
    damping : float or None
        Background viscous drag coefficient b (force -b v on every flowing particle), or None.
    walls : sequence of Wall or CylinderWall
    timestep : float
    """

    name: str
    box: Box
    positions: np.ndarray
    radii: np.ndarray
    masses: np.ndarray
    contacts: ContactModel
    fixed: np.ndarray = None
    velocities: np.ndarray = None
    gravity: np.ndarray = None
    rotation: bool = True
    damping: float = None
    walls: tuple = field(default_factory=tuple)
    timestep: float = PAPER_TIMESTEP

    def __post_init__(self):
        if not isinstance(self.box, Box):
            raise TypeError(f"box: expected a cg.Box, got {type(self.box).__name__}")
        dim = self.box.dim
        self.positions = real_array(self.positions, "positions", ndim=2)
        n = self.positions.shape[0]
        if self.positions.shape[1] != dim:
            raise ValueError(f"positions: expected shape (N, {dim}) like the box, got {self.positions.shape}")
        self.radii = real_array(self.radii, "radii", ndim=1, shape=(n,))
        if np.any(self.radii <= 0):
            raise ValueError("radii: expected positive radii")
        self.masses = real_array(self.masses, "masses", ndim=1, shape=(n,))
        if np.any(self.masses <= 0):
            raise ValueError("masses: expected positive masses")
        self.fixed = np.zeros(n, bool) if self.fixed is None else np.asarray(self.fixed, bool)
        if self.fixed.shape != (n,):
            raise ValueError(f"fixed: expected shape ({n},), got {self.fixed.shape}")
        if self.velocities is not None:
            self.velocities = real_array(self.velocities, "velocities", ndim=2, shape=(n, dim))
        if self.gravity is not None:
            self.gravity = real_array(self.gravity, "gravity", ndim=1, shape=(dim,))
        if not isinstance(self.contacts, ContactModel):
            raise TypeError(f"contacts: expected a ContactModel, got {type(self.contacts).__name__}")
        if self.damping is not None and not (np.isfinite(self.damping) and self.damping > 0):
            raise ValueError(f"damping: expected a positive drag coefficient or None, got {self.damping!r}")
        self.walls = tuple(self.walls)
        for wall in self.walls:
            if isinstance(wall, CylinderWall):
                if dim != 3:
                    raise ValueError("walls: a CylinderWall needs a 3D scene")
                continue
            if not isinstance(wall, Wall):
                raise TypeError(f"walls: expected Wall or CylinderWall objects, got {type(wall).__name__}")
            if wall.axis not in self.axis_names:
                raise ValueError(f"walls: axis {wall.axis!r} is not an axis of this {dim}D scene")
            if self.box.periodic[self.axis_names.index(wall.axis)]:
                raise ValueError(f"walls: axis {wall.axis!r} is periodic")
        if not (np.isfinite(self.timestep) and self.timestep > 0):
            raise ValueError(f"timestep: expected a positive number, got {self.timestep!r}")

    @property
    def dim(self):
        return self.box.dim

    @property
    def axis_names(self):
        return ("x", "z") if self.dim == 2 else AXIS_NAMES

    @property
    def n_particles(self):
        return self.positions.shape[0]

    @property
    def effects(self):
        """The physical effects this scene needs, as short names (what the engine input will contain)."""
        c = self.contacts
        out = [f"{self.dim}D", "normal contact force"]
        if c.gamma_n > 0:
            out.append("normal contact damping")
        if c.tangential:
            out.append("tangential contact force")
            if c.gamma_t > 0:
                out.append("tangential contact damping")
            if c.friction > 0:
                out.append("sliding friction")
        if self.rotation:
            out.append("rotation")
        if self.gravity is not None and np.any(self.gravity != 0):
            out.append("gravity")
        if self.damping is not None:
            out.append("background damping")
        if np.any(self.fixed):
            out.append("fixed particles")
        if any(isinstance(w, Wall) for w in self.walls):
            out.append("walls")
        if any(isinstance(w, CylinderWall) for w in self.walls):
            out.append("cylinder wall")
        out += [f"periodic {a}" for a, p in zip(self.axis_names, self.box.periodic) if p]
        return tuple(out)

    def __repr__(self):
        return (f"<Scene {self.name!r}: {self.n_particles} particles ({int(self.fixed.sum())} fixed), "
                f"{', '.join(self.effects)}>")
