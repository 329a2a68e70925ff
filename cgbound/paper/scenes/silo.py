"""A cylindrical silo: frictional spheres in a vertical cylinder with a flat bottom, under gravity.

Filled and left to come to rest, the column shows the Janssen effect: wall friction carries part
of the weight, so the vertical stress and the wall shear stress saturate with depth instead of
growing hydrostatically. The silo's wall is a :class:`~cgbound.paper.scenes.CylinderWall`
(LAMMPS ``fix wall/gran/region`` with a cylinder region and its ``contacts`` output), the bottom a
:class:`~cgbound.paper.scenes.Wall`, so every force from the boundary is a wall contact.

Units: mean particle diameter d = 1, particle density such that a d = 1 sphere has m = 1, g = 1.
"""
import numpy as np

from ...box import Box
from .scene import CylinderWall, ContactModel, Scene, Wall

#: silo contacts: softer than the paper's (kn = 2e4, t_c = 0.016 for two unit masses) so that a
#: column of a few thousand particles settles in minutes; restitution 0.5 between unit masses.
#: The wall contacts use the same model (sliding friction 0.5 against the wall too).
SILO_CONTACT_MODEL = ContactModel(kn=2e4, gamma_n=88.0, kt=2.0 / 7.0 * 2e4, gamma_t=44.0, friction=0.5)
#: a round time step below a fiftieth of the collision time of the smallest pair (0.0137 / 50 for d = 0.9)
SILO_TIMESTEP = 2.5e-4


def silo(n_particles=2000, radius=4.0, polydispersity=0.2, contacts=SILO_CONTACT_MODEL, timestep=SILO_TIMESTEP,
         seed=18):
    """A silo of ``radius`` (diameter D = 2 radius) filled with ``n_particles`` spheres, at rest.

    The particles (diameters uniform in 1 +- polydispersity/2, mass proportional to d^3, m = 1
    for d = 1) start on a loose cubic lattice of spacing 1.2 inside the cylinder, jittered at
    random, and fall onto the bottom wall at z = 0: a :class:`Settle` stage then brings them to rest.
    """
    if not (isinstance(n_particles, (int, np.integer)) and n_particles >= 1):
        raise ValueError(f"n_particles: expected a positive integer, got {n_particles!r}")
    if not (np.isfinite(radius) and radius >= 2.0):
        raise ValueError(f"radius: expected a silo radius of at least 2 particle diameters, got {radius!r}")
    if not (np.isfinite(polydispersity) and 0 <= polydispersity < 0.5):
        raise ValueError(f"polydispersity: expected a number in [0, 0.5), got {polydispersity!r}")
    rng = np.random.default_rng(seed)
    spacing = 1.2
    d_max = 1.0 + 0.5 * polydispersity
    jitter = 0.5 * (spacing - d_max)
    # lattice sites whose jittered particles stay clear of the wall
    reach = radius - 0.5 * d_max - jitter
    k = np.arange(-int(reach / spacing) - 1, int(reach / spacing) + 2) * spacing
    gx, gy = np.meshgrid(k, k, indexing="ij")
    inside = gx ** 2 + gy ** 2 <= reach ** 2
    layer = np.stack([gx[inside], gy[inside]], axis=1)
    n_layers = -(-n_particles // len(layer))
    z0 = 0.5 * d_max + jitter
    sites = np.concatenate([np.column_stack([layer, np.full(len(layer), z0 + spacing * n)]) for n in range(n_layers)])
    positions = sites[:n_particles] + rng.uniform(-jitter, jitter, (n_particles, 3)) / np.sqrt(3.0)
    diameters = rng.uniform(1.0 - 0.5 * polydispersity, 1.0 + 0.5 * polydispersity, n_particles)
    masses = diameters ** 3
    top = float(positions[:, 2].max()) + 1.0
    box = Box([-radius - 1.0, -radius - 1.0, -1.0], [radius + 1.0, radius + 1.0, top], periodic=False)
    walls = (CylinderWall("z", (0.0, 0.0), radius), Wall("z", 0.0, "above"))
    return Scene(f"silo_R{radius:g}_N{n_particles}", box, positions, 0.5 * diameters, masses, contacts,
                 gravity=np.array([0.0, 0.0, -1.0]), rotation=True, walls=walls, timestep=timestep)


__all__ = ["SILO_CONTACT_MODEL", "SILO_TIMESTEP", "silo"]
