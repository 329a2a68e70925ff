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
}

#: fields whose sign depends on the stress convention
STRESS_FIELDS = ("kinetic_stress", "contact_stress", "boundary_stress", "stress", "extended_stress")

CONVENTIONS = ("tension", "compression")


def field_rank(name):
    """Rank per node of field ``name``."""
    return FIELDS[name][0]


def check_fields(fields):
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
        if name not in FIELDS:
            raise ValueError(f"fields: expected some of {', '.join(FIELDS)}, got unknown field {name!r}")
    return tuple(dict.fromkeys(fields))


def check_convention(convention):
    if not isinstance(convention, str):
        raise TypeError(f"convention: expected 'tension' or 'compression', got {convention!r}")
    if convention not in CONVENTIONS:
        raise ValueError(f"convention: expected 'tension' (the paper's sign) or 'compression' (MercuryCG's), "
                         f"got {convention!r}")
    return convention


def needed_primaries(fields):
    """The primaries (names in PRIMARIES) the fields need."""
    needed = set()
    for name in fields:
        needed.update(FIELDS[name][1])
    return needed


def derive(primaries, fields, u_ref, dim, convention):
    """Requested fields (flat over nodes, C-contiguous) from averaged primaries.

    A field equal to a C-contiguous primary is that array itself, not a copy: callers pass
    primaries they no longer need (and no two fields share one).
    """
    pr = primaries
    own = np.ascontiguousarray
    out = {}
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
