"""Which continuum fields exist, which primary sums each needs, and how it is derived from them.

A snapshot is reduced to *primary* sums (:mod:`cgbound.primaries`; one kernel pass each, computed
only when a requested field needs them); requested fields are derived from the primaries after
any averaging over snapshots.
"""
import numpy as np


#: field name -> (rank, primaries it needs); every primary is in cgbound.primaries.PRIMARIES
FIELDS = {
    "density": (0, ("rho",)),
    "momentum": (1, ("rho", "p_w")),
    "velocity": (1, ("rho", "p_w")),
    "momentum_flux": (2, ("k",)),
    "kinetic_stress": (2, ("rho", "p_w", "sk")),
    "contact_stress": (2, ("sb",)),
    "boundary_stress": (2, ("sw",)),
    "interaction_force_density": (1, ("t",)),
    "body_force_density": (1, ("b",)),
    "stress": (2, ("rho", "p_w", "sk", "sb", "sw")),
    "extended_stress": (2, ("rho", "p_w", "sk", "sb", "sx")),
    "volume_fraction": (0, ("phi",)),
    "pressure": (0, ("rho", "p_w", "sk", "sb", "sw")),
    "temperature": (0, ("rho", "p_w", "sk")),
    # structure (docs/theory.md, "Structure")
    "number_density": (0, ("nd",)),
    "fabric": (2, ("fb", "fw")),
    "coordination_number": (0, ("nd", "fb", "fw")),
    **{f"size_moment_{k}": (0, ("nd",) if k == 0 else (f"r{k}",)) for k in range(6)},
    "mean_radius": (0, ("nd", "r1")),
    "radius_spread": (0, ("nd", "r1", "r2")),
    "radius_skewness": (0, ("nd", "r1", "r2", "r3")),
    # gradients and rheology (docs/theory.md, "Gradients, kinematics and rheology")
    "density_gradient": (1, ("grad_rho",)),
    "momentum_gradient": (2, ("grad_rho", "grad_p_w")),
    "velocity_gradient": (2, ("rho", "p_w", "grad_rho", "grad_p_w")),
    "strain_rate": (2, ("rho", "p_w", "grad_rho", "grad_p_w")),
    "spin": (2, ("rho", "p_w", "grad_rho", "grad_p_w")),
    "shear_rate": (0, ("rho", "p_w", "grad_rho", "grad_p_w")),
    "shear_stress": (0, ("rho", "p_w", "sk", "sb", "sw")),
    "friction": (0, ("rho", "p_w", "sk", "sb", "sw")),
    "inertial_number": (0, ("rho", "p_w", "grad_rho", "grad_p_w", "sk", "sb", "sw", "phi", "phi_d")),
    # rotation (docs/theory.md, "Rotation and couple stress"): the rank counts pseudo-vector indices too,
    # whose length is 3 in 3D and which vanish in 2D (see field_shape); the couple stress and the torque
    # densities are given in the contact-point form here (COUPLE_STRESS_FORMS for the other)
    "spin_density": (1, ("spin",)),
    "angular_momentum_density": (1, ("spin",)),
    "spin_flux": (2, ("spin_flux",)),
    "kinetic_spin_flux": (2, ("rho", "p_w", "spin", "spin_flux_w")),
    "couple_stress": (2, ("couple",)),
    "stress_torque_density": (1, ("pair_torque",)),
    "boundary_couple_density": (1, ("wall_couple",)),
}

#: fields that need the kernel's gradient (a differentiable kernel: Gaussian or Lucy)
GRADIENT_FIELDS = ("density_gradient", "momentum_gradient", "velocity_gradient", "strain_rate", "spin",
                   "shear_rate", "inertial_number")

#: fields whose sign depends on the stress convention
STRESS_FIELDS = ("kinetic_stress", "contact_stress", "boundary_stress", "stress", "extended_stress")

CONVENTIONS = ("tension", "compression")


def field_rank(name):
    """Number of indices per node of field ``name`` in 3D (pseudo-vector indices included; see field_shape)."""
    return FIELDS[name][0]


#: the rotational fields (docs/theory.md, "Rotation and couple stress")
ROTATION_FIELDS = ("spin_density", "angular_momentum_density", "spin_flux", "couple_stress",
                   "stress_torque_density", "boundary_couple_density", "kinetic_spin_flux")

#: fields with a pseudo-vector index (angular velocities, torques: 3 components in 3D, one out-of-plane
#: component in 2D, stored without an index): name -> the kind of each index, "pseudo" or "vector" (D)
FIELD_INDICES = {
    "spin_density": ("pseudo",),
    "angular_momentum_density": ("pseudo",),
    "spin_flux": ("pseudo", "vector"),
    "kinetic_spin_flux": ("pseudo", "vector"),
    "couple_stress": ("pseudo", "vector"),
    "stress_torque_density": ("pseudo",),
    "boundary_couple_density": ("pseudo",),
}


def field_shape(name, dim):
    """Shape per node of field ``name`` in ``dim`` dimensions: (D,) per vector index, (3,) per pseudo-vector
    index in 3D and nothing for it in 2D. E.g. stress (D, D); spin_density (3,) in 3D, () in 2D;
    couple_stress (3, 3) in 3D, (2,) in 2D."""
    kinds = FIELD_INDICES.get(name, ("vector",) * FIELDS[name][0])
    shape = ()
    for kind in kinds:
        if kind == "vector":
            shape += (dim,)
        elif dim == 3:
            shape += (3,)
    return shape


def field_size(name, dim):
    """Doubles per node of field ``name`` in ``dim`` dimensions."""
    return int(np.prod(field_shape(name, dim), dtype=int))


#: how the couple stress splits the contact torques (docs/theory.md, "Rotation and couple stress"):
#: "contact_point" puts the torque densities at the contact points; "branch_line" makes the torque
#: density the antisymmetric part of the paper's stress (eps : sigma), spread along the branch lines
COUPLE_STRESS_FORMS = ("contact_point", "branch_line")
DEFAULT_COUPLE_STRESS_FORM = "contact_point"
#: the primaries of the branch-line form in place of those of the contact-point form
BRANCH_LINE_PRIMARIES = {"couple": "couple_bl", "pair_torque": "pair_torque_bl", "wall_couple": "wall_couple_bl"}


def check_couple_stress_form(form):
    if not isinstance(form, str) or form not in COUPLE_STRESS_FORMS:
        raise ValueError(f"couple_stress_form: expected 'contact_point' or 'branch_line', got {form!r}")
    return form


def check_fields(fields, known=None):
    """The requested field names as a tuple without repeats; ``known``: the names allowed (default FIELDS)."""
    known = FIELDS if known is None else known
    if isinstance(fields, str):
        fields = (fields,)
    try:
        fields = tuple(fields)
    except TypeError:
        raise TypeError(f"fields: expected a sequence of field names, got {fields!r}") from None
    if not fields:
        raise ValueError("fields: expected at least one field name, got none")
    for name in fields:
        if not isinstance(name, str):
            raise TypeError(f"fields: expected field names (strings), got {name!r}")
        if name not in known:
            raise ValueError(f"fields: expected some of {', '.join(known)}, got unknown field {name!r}")
    return tuple(dict.fromkeys(fields))


def check_convention(convention):
    if not isinstance(convention, str):
        raise TypeError(f"convention: expected 'tension' or 'compression', got {convention!r}")
    if convention not in CONVENTIONS:
        raise ValueError(f"convention: expected 'tension' (the paper's sign) or 'compression' (MercuryCG's), "
                         f"got {convention!r}")
    return convention


def check_differentiable(kernel, fields):
    """Raise before any work if a field needs the gradient of a kernel that has none (Heaviside)."""
    for name in fields:
        if name in GRADIENT_FIELDS and not kernel.differentiable:
            raise ValueError(f"kernel: expected a differentiable kernel (Gaussian or Lucy) for the field {name!r}, "
                             f"got {kernel!r}")


def needed_primaries(fields, couple_stress_form=DEFAULT_COUPLE_STRESS_FORM):
    """The primaries (names in PRIMARIES) the fields need."""
    needed = set()
    for name in fields:
        needed.update(FIELDS[name][1])
    if couple_stress_form == "branch_line":
        needed = {BRANCH_LINE_PRIMARIES.get(p, p) for p in needed}
    return needed


def derive(primaries, fields, u_ref, dim, convention):
    """Requested fields (flat over nodes, C-contiguous) from averaged primaries.

    A field equal to a C-contiguous primary is that array itself, not a copy: callers pass
    primaries they no longer need (and no two fields share one).
    """
    pr = primaries
    own = np.ascontiguousarray
    out = {}
    memo = {}          # intermediate fields shared by the rheology fields
    rho = pr.get("rho")
    sign = -1.0 if convention == "compression" else 1.0

    def velocity_w():
        V = np.full(pr["p_w"].shape, np.nan)
        np.divide(pr["p_w"], rho[:, None], out=V, where=rho[:, None] > 0)
        return V

    for name in fields:
        if name == "density":
            value = own(rho)
        elif name == "momentum":
            value = np.empty(pr["p_w"].shape)
            for r in range(dim):                       # p_w + rho u_ref, column by column
                np.multiply(rho, u_ref[r], out=value[:, r])
                np.add(pr["p_w"][:, r], value[:, r], out=value[:, r])
        elif name == "velocity":
            value = velocity_w() + u_ref
        elif name == "momentum_flux":
            value = own(pr["k"])
        elif name == "kinetic_stress":
            value = own(pr["sk"]) if sign == 1.0 else sign * pr["sk"]
        elif name == "contact_stress":
            value = own(pr["sb"]) if sign == 1.0 else sign * pr["sb"]
        elif name == "boundary_stress":
            value = own(pr["sw"]) if sign == 1.0 else sign * pr["sw"]
        elif name == "interaction_force_density":
            value = own(pr["t"])
        elif name == "body_force_density":
            value = own(pr["b"])
        elif name == "stress":
            value = sign * (pr["sk"] + pr["sb"] + pr["sw"])
        elif name == "extended_stress":
            value = sign * (pr["sk"] + pr["sb"] + pr["sx"])
        elif name == "volume_fraction":
            value = own(pr["phi"])
        elif name == "pressure":
            value = -np.trace(pr["sk"] + pr["sb"] + pr["sw"], axis1=1, axis2=2) / dim
        elif name == "temperature":
            value = np.full(rho.shape, np.nan)
            np.divide(-np.trace(pr["sk"], axis1=1, axis2=2), dim * rho, out=value, where=rho > 0)
        elif name in STRUCTURE_FIELDS:
            value = structure_field(name, pr)
        elif name in RHEOLOGY_FIELDS:
            value = rheology_field(name, pr, u_ref, dim, memo)
        elif name in ROTATION_FIELDS:
            value = rotation_field(name, pr, dim)
        out[name] = value
    return out


#: averages per particle: NaN where the number density is zero, as the velocity is where the density is
PER_PARTICLE_FIELDS = ("coordination_number", "mean_radius", "radius_spread", "radius_skewness")

#: the structure fields (docs/theory.md, "Structure"), derived by structure_field
STRUCTURE_FIELDS = ("number_density", "fabric", "coordination_number", "mean_radius", "radius_spread",
                    "radius_skewness") + tuple(f"size_moment_{k}" for k in range(6))


def _per_particle(sum_, nd):
    """sum_ / nd where the number density is positive, NaN elsewhere (no particle there to average over)."""
    out = np.full(nd.shape, np.nan)
    np.divide(sum_, nd, out=out, where=nd > 0)
    return out


def structure_field(name, pr):
    """One structure field from the averaged primaries ``pr`` (flat over nodes)."""
    if name in ("number_density", "size_moment_0"):
        return np.array(pr["nd"])
    if name.startswith("size_moment_"):
        return np.array(pr["r" + name[-1]])
    if name == "fabric":
        return pr["fb"] + pr["fw"]
    if name == "coordination_number":
        # a bulk contact touches two flowing particles, a boundary contact one
        return _per_particle(2.0 * np.trace(pr["fb"], axis1=1, axis2=2) + np.trace(pr["fw"], axis1=1, axis2=2),
                             pr["nd"])
    mean = _per_particle(pr["r1"], pr["nd"])
    if name == "mean_radius":
        return mean
    # central moments from the raw ones; clipped at 0 where rounding leaves a tiny negative variance
    variance = np.maximum(_per_particle(pr["r2"], pr["nd"]) - mean ** 2, 0.0)
    spread = np.sqrt(variance)
    if name == "radius_spread":
        return spread
    third = _per_particle(pr["r3"], pr["nd"]) - 3.0 * mean * variance - mean ** 3
    return _per_particle(third, spread ** 3)    # radius_skewness: NaN where the sizes do not spread
# --- gradients, kinematics and rheology (docs/theory.md, "Gradients, kinematics and rheology") ---

RHEOLOGY_FIELDS = ("density_gradient", "momentum_gradient", "velocity_gradient", "strain_rate", "spin",
                   "shear_rate", "shear_stress", "friction", "inertial_number")
#: NaN where the density is zero (they divide by it), like velocity and temperature
NAN_WITHOUT_MATTER = ("velocity_gradient", "strain_rate", "spin", "shear_rate", "inertial_number")
#: NaN where the pressure is not positive; they divide by it, so their round-off grows like 1/p where it
#: crosses zero
PRESSURE_RATIO_FIELDS = ("friction", "inertial_number")


def velocity_gradient(rho, p_w, grad_rho, grad_p_w):
    """L_ab = dV_a/dr_b = (dp_a/dr_b - V_a drho/dr_b) / rho (NaN where rho = 0); the reference velocity
    cancels, so the momenta relative to it are used."""
    L = np.full(grad_p_w.shape, np.nan)
    has = rho > 0
    V = p_w[has] / rho[has][:, None]
    L[has] = (grad_p_w[has] - V[:, :, None] * grad_rho[has][:, None, :]) / rho[has][:, None, None]
    return L


def deviator(tensor):
    """tensor - (tr tensor / D) I, per node."""
    dim = tensor.shape[-1]
    out = tensor.copy()
    mean = np.trace(tensor, axis1=-2, axis2=-1) / dim
    for a in range(dim):
        out[..., a, a] -= mean
    return out


def shear_rate_of(strain):
    """gamma_dot = sqrt(2 D':D'), D' the deviatoric strain rate."""
    dev = deviator(strain)
    return np.sqrt(2.0 * np.einsum("...ab,...ab->...", dev, dev))


def shear_stress_of(stress):
    """|tau| = sqrt(tau':tau' / 2) of the deviatoric part tau' of the (symmetrised) stress; the same in
    either sign convention."""
    sym = 0.5 * (stress + np.swapaxes(stress, -1, -2))
    dev = deviator(sym)
    return np.sqrt(0.5 * np.einsum("...ab,...ab->...", dev, dev))


def rheology_field(name, pr, u_ref, dim, memo):
    """One of RHEOLOGY_FIELDS from the averaged primaries; ``memo`` keeps intermediate fields shared by
    several requested fields (L, D, the stress, the pressure)."""
    def get(key, make):
        if key not in memo:
            memo[key] = make()
        return memo[key]

    L = lambda: get("L", lambda: velocity_gradient(pr["rho"], pr["p_w"], pr["grad_rho"], pr["grad_p_w"]))
    D = lambda: get("D", lambda: 0.5 * (L() + np.swapaxes(L(), 1, 2)))
    sigma = lambda: get("sigma", lambda: pr["sk"] + pr["sb"] + pr["sw"])           # tension convention
    pressure = lambda: get("p", lambda: -np.trace(sigma(), axis1=1, axis2=2) / dim)
    tau = lambda: get("tau", lambda: shear_stress_of(sigma()))
    gamma = lambda: get("gamma", lambda: shear_rate_of(D()))

    def positive_ratio(num, den):
        out = np.full(num.shape, np.nan)
        np.divide(num, den, out=out, where=den > 0)
        return out

    if name == "density_gradient":
        return np.ascontiguousarray(pr["grad_rho"])
    if name == "momentum_gradient":
        return pr["grad_p_w"] + u_ref[None, :, None] * pr["grad_rho"][:, None, :]
    if name == "velocity_gradient":
        return L().copy()
    if name == "strain_rate":
        return D().copy()
    if name == "spin":
        return 0.5 * (L() - np.swapaxes(L(), 1, 2))
    if name == "shear_rate":
        return gamma().copy()
    if name == "shear_stress":
        return tau().copy()
    if name == "friction":
        return positive_ratio(tau(), pressure())
    # inertial number I = gamma_dot d sqrt(rho_p / p), d = phi_d / phi, rho_p = rho / phi (NaN where p <= 0)
    phi = pr["phi"]
    d_mean = positive_ratio(pr["phi_d"], phi)
    rho_p = positive_ratio(pr["rho"], phi)
    return gamma() * d_mean * np.sqrt(positive_ratio(rho_p, pressure()))


# --- rotation (docs/theory.md, "Rotation and couple stress") ---

def rotation_field(name, pr, dim):
    """One of ROTATION_FIELDS from the averaged primaries (flat over nodes, pseudo-vector index of length T =
    3 in 3D and 1 in 2D); the couple stress and torque densities of whichever form was summed."""
    if name in ("spin_density", "angular_momentum_density"):
        return np.array(pr["spin"])
    if name == "spin_flux":
        return np.array(pr["spin_flux"])
    if name == "kinetic_spin_flux":
        # J' = sum_i I_i w_i (x) (v_i - V) W_i = J_w - s (x) V_w about the local velocity (0 where rho = 0,
        # where every sum vanishes); the reference velocity cancels
        rho = pr["rho"]
        V_w = np.zeros(pr["p_w"].shape)
        np.divide(pr["p_w"], rho[:, None], out=V_w, where=rho[:, None] > 0)
        return pr["spin_flux_w"] - pr["spin"][:, :, None] * V_w[:, None, :]
    key = {"couple_stress": "couple", "stress_torque_density": "pair_torque",
           "boundary_couple_density": "wall_couple"}[name]
    return np.array(pr[key] if key in pr else pr[BRANCH_LINE_PRIMARIES[key]])
