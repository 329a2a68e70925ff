"""Chutes at several inclinations for the granular rheology mu(I) (Silbert et al. 2001; GDR MiDi 2004).

The same periodic chute as the paper's (:func:`cgbound.paper.scenes.chute`: a random rough base of
fixed particles, gravity tilted by the inclination, frictional spring-dashpot contacts with rotation,
nothing else), sized and stiffened for a steady flow that is cheap to reach at each of several angles:

* a base of fixed particles as large as the mean flowing one (d = 1), as in Silbert et al. (2001);
* flowing diameters drawn uniformly from [0.9, 1.1] d (monodisperse spheres crystallise into layers that
  slide over each other and accelerate at some inclinations);
* contacts ten times softer than the paper's (kn = 2e4 m g / d, still ~1e-3 d of overlap at the
  bottom of the flow, the rigid limit where mu(I) does not depend on kn), with the damping scaled
  by sqrt(10) so that the restitution stays the paper's e = 0.88, and the paper's kt = 2/7 kn
  and sliding friction 0.5;
* a time step of t_c / 31 (t_c = 0.0157 sqrt(d / g) for two flowing particles of d = 1; t_c / 27 for
  the smallest pair).

Units: flowing particle diameter d = 1, mass m = 1, gravity g = 1 (like the paper's scenes).
"""
import numpy as np

from .paper import chute
from .scene import ContactModel

#: the paper's contact model ten times softer, with the paper's restitution (0.883) and friction
RHEOLOGY_CONTACT_MODEL = ContactModel(kn=2e4, gamma_n=50.0 / np.sqrt(10.0), kt=2.0 / 7.0 * 2e4,
                                      gamma_t=50.0 / np.sqrt(10.0), friction=0.5)
#: t_c / 31 for RHEOLOGY_CONTACT_MODEL
RHEOLOGY_TIMESTEP = 5e-4


def inclined_chute(angle, n_flowing=1300, length=10.0, width=10.0, base_diameter=1.0, flowing_diameters=(0.9, 1.1),
                   contacts=RHEOLOGY_CONTACT_MODEL, timestep=RHEOLOGY_TIMESTEP, seed=17):
    """A periodic chute inclined at ``angle`` degrees for mu(I): 1300 flowing particles (diameters 0.9-1.1,
    a flow ~12 d deep) on a 10 x 10 rough base of fixed particles of diameter 1, starting at rest (see the
    module docstring).

    The scene's x axis points down the slope and z is normal to the base; gravity is
    (sin(angle), 0, -cos(angle)). The same ``seed`` gives the same base and initial positions at every angle.
    """
    angle = float(angle)
    if not (np.isfinite(angle) and 0.0 < angle < 90.0):
        raise ValueError(f"angle: expected an inclination in degrees between 0 and 90, got {angle!r}")
    scene = chute(n_flowing=n_flowing, length=length, width=width, angle=angle, base_diameter=base_diameter,
                  flowing_diameters=flowing_diameters, contacts=contacts, timestep=timestep, seed=seed)
    scene.name = f"inclined_chute_{angle:g}deg_N{n_flowing}"
    return scene


__all__ = ["RHEOLOGY_CONTACT_MODEL", "RHEOLOGY_TIMESTEP", "inclined_chute"]
