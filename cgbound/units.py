"""Units of particle data and of the fields coarse-grained from it.

cgbound computes in whatever units the particle data are in; it never converts. A :class:`Units`
says what those units are, so that every field can name its own unit (stress in a 3-D ``si`` run is
``kg m^-1 s^-2``; in ``lj`` units it is ``m / (σ τ²)``) in plot labels and in the ``units``
attributes of HDF5, xarray and VTK output. Without units, labels say "(simulation units)".

A field's unit follows from its dimension, exponents of (mass, length, time) in :data:`DIMENSIONS`;
coarse-grained densities are per unit D-volume, so in 2-D a density is a mass per area (see
:func:`dimension`).

Named systems (:data:`SYSTEMS`, :func:`as_units`):

* the LAMMPS ``units`` styles ``lj``, ``si``, ``cgs``, ``real``, ``metal``, ``micro``, ``nano``, with
  the mass, distance, time and force units the LAMMPS ``units`` command defines. In ``real`` and
  ``metal`` the force unit (kcal/mol-Å, eV/Å) is not mass x length / time^2, so stresses from contact
  forces and stresses from velocities are in different units there: :func:`check_fields` refuses a
  field that adds the two (stress, extended_stress, pressure), and the others say which unit they are in;
* ``mercury``: MercuryDPM-style dimensionless units, with the particle diameter d, the particle mass m
  and the gravity g set to 1 (time unit √(d/g)); a stress is then in ``m g / d²``.

Nothing here imports from above this module (it sits with the snapshot, layer 1).
"""
from fractions import Fraction
from typing import NamedTuple, Optional

#: Avogadro's number (exact since SI 2019); LAMMPS' g/mol is 1e-3 / N_A kg
AVOGADRO = 6.02214076e23
ELECTRON_VOLT = 1.602176634e-19       # J
KILOCALORIE = 4184.0                  # J (thermochemical calorie, as LAMMPS)


class Units(NamedTuple):
    """The units of a snapshot's numbers.

    Parameters
    ----------
    length, mass, time : str
        Names of the units as written in files (ASCII, e.g. ``"m"``, ``"kg"``, ``"s"``).
    length_si, mass_si, time_si : float, optional
        The size of each unit in metres, kilograms, seconds (None for reduced units such as ``lj``).
    name : str, optional
        The named system (``"si"``, ``"lj"``, ...), None for units made by hand.
    symbols : (str, str, str), optional
        How labels write (length, mass, time) (e.g. ``("σ", "m", "τ")``); default the names.
    force, force_si : str, float, optional
        Only when the force unit is NOT mass x length / time^2 (LAMMPS ``real``, ``metal``): its name and
        size in newtons. Fields made of contact forces are then in force units.
    gravity : bool
        Time in units of √(length / g) (MercuryDPM-style): labels write g instead of the time unit.
    """
    length: str
    mass: str
    time: str
    length_si: Optional[float] = None
    mass_si: Optional[float] = None
    time_si: Optional[float] = None
    name: Optional[str] = None
    symbols: Optional[tuple] = None
    force: Optional[str] = None
    force_si: Optional[float] = None
    gravity: bool = False

    @property
    def consistent(self):
        """True when force = mass x length / time^2 (every field then has one unit)."""
        return self.force is None

    def __str__(self):
        what = f"{self.name} units: " if self.name else "units: "
        parts = [f"length {self.length}", f"mass {self.mass}", f"time {self.time}"]
        if self.force:
            parts.append(f"force {self.force}")
        return what + ", ".join(parts)

    def as_dict(self):
        """A plain dict (for JSON metadata); :func:`as_units` takes it back."""
        out = {k: v for k, v in self._asdict().items() if v is not None and v is not False}
        if "symbols" in out:
            out["symbols"] = list(out["symbols"])
        return out


def _lammps_mass_g_per_mol():
    return 1e-3 / AVOGADRO


#: named systems; the LAMMPS ones as the LAMMPS ``units`` command defines them
SYSTEMS = {
    "lj": Units("sigma", "m", "tau", name="lj", symbols=("σ", "m", "τ")),
    "si": Units("m", "kg", "s", 1.0, 1.0, 1.0, name="si"),
    "cgs": Units("cm", "g", "s", 1e-2, 1e-3, 1.0, name="cgs"),
    "real": Units("Angstrom", "g/mol", "fs", 1e-10, _lammps_mass_g_per_mol(), 1e-15, name="real",
                  symbols=("Å", "g/mol", "fs"), force="kcal/mol/Angstrom",
                  force_si=KILOCALORIE / AVOGADRO / 1e-10),
    "metal": Units("Angstrom", "g/mol", "ps", 1e-10, _lammps_mass_g_per_mol(), 1e-12, name="metal",
                   symbols=("Å", "g/mol", "ps"), force="eV/Angstrom", force_si=ELECTRON_VOLT / 1e-10),
    "micro": Units("um", "pg", "us", 1e-6, 1e-15, 1e-6, name="micro", symbols=("µm", "pg", "µs")),
    "nano": Units("nm", "ag", "ns", 1e-9, 1e-21, 1e-9, name="nano"),
    "mercury": Units("d", "m", "sqrt(d/g)", name="mercury", symbols=("d", "m", "√(d/g)"), gravity=True),
}


class Dimension(NamedTuple):
    """Exponents of (mass, length, time); ``per_volume``: divided once more by a D-volume (length^D)."""
    mass: int
    length: int
    time: int
    per_volume: bool = False
    #: how the field is made: "kinetic" (from velocities), "force" (from contact or body forces),
    #: "mixed" (the sum of both), or "" (neither: mass, length, time only)
    made_of: str = ""


#: field name -> its Dimension (every field of cgbound.fields.FIELDS has one; tests check it)
DIMENSIONS = {
    "density": Dimension(1, 0, 0, True),
    "momentum": Dimension(1, 1, -1, True),
    "velocity": Dimension(0, 1, -1),
    "momentum_flux": Dimension(1, 2, -2, True, "kinetic"),
    "kinetic_stress": Dimension(1, 2, -2, True, "kinetic"),
    "contact_stress": Dimension(1, 2, -2, True, "force"),
    "boundary_stress": Dimension(1, 2, -2, True, "force"),
    "interaction_force_density": Dimension(1, 1, -2, True, "force"),
    "body_force_density": Dimension(1, 1, -2, True, "force"),
    "stress": Dimension(1, 2, -2, True, "mixed"),
    "extended_stress": Dimension(1, 2, -2, True, "mixed"),
    "volume_fraction": Dimension(0, 0, 0),
    "pressure": Dimension(1, 2, -2, True, "mixed"),
    "temperature": Dimension(0, 2, -2, False, "kinetic"),   # mass-weighted velocity variance (no k_B)
    "number_density": Dimension(0, 0, 0, True),
    "fabric": Dimension(0, 0, 0, True),                     # contacts per volume
    "coordination_number": Dimension(0, 0, 0),
    **{f"size_moment_{k}": Dimension(0, k, 0, True) for k in range(6)},
    "mean_radius": Dimension(0, 1, 0),
    "radius_spread": Dimension(0, 1, 0),
    "radius_skewness": Dimension(0, 0, 0),
    "density_gradient": Dimension(1, -1, 0, True),
    "momentum_gradient": Dimension(1, 0, -1, True),
    "velocity_gradient": Dimension(0, 0, -1),
    "strain_rate": Dimension(0, 0, -1),
    "spin": Dimension(0, 0, -1),
    "shear_rate": Dimension(0, 0, -1),
    "shear_stress": Dimension(1, 2, -2, True, "mixed"),
    "friction": Dimension(0, 0, 0),
    "inertial_number": Dimension(0, 0, 0),
    # rotation (cgbound.rotation_fields; docs/theory.md, "Rotation and couple stress")
    "spin_density": Dimension(1, 2, -1, True, "kinetic"),              # I w per volume
    "angular_momentum_density": Dimension(1, 2, -1, True, "kinetic"),  # the intrinsic part: the spin density
    "spin_flux": Dimension(1, 3, -2, True, "kinetic"),                 # I w v per volume
    "couple_stress": Dimension(1, 3, -2, True, "force"),               # torque x length per volume
    "stress_torque_density": Dimension(1, 2, -2, True, "force"),       # torque per volume
    "boundary_couple_density": Dimension(1, 2, -2, True, "force"),
    "kinetic_spin_flux": Dimension(1, 3, -2, True, "kinetic"),         # I w v' per volume
}

#: quantities that are not fields but have units too (coordinates, times, masses)
QUANTITIES = {"length": Dimension(0, 1, 0), "mass": Dimension(1, 0, 0), "time": Dimension(0, 0, 1)}

#: what labels say when the units are not known
SIMULATION_UNITS = "simulation units"


def as_units(units, name="units"):
    """A :class:`Units` from a Units, a system name (``"si"``, ``"lj"``, ...), a mapping with keys
    ``length``, ``mass``, ``time`` (and optionally the other fields of Units), or None (unknown)."""
    if units is None or isinstance(units, Units):
        return units
    if isinstance(units, str):
        key = units.strip().lower()
        if key not in SYSTEMS:
            raise ValueError(f"{name}: expected one of {', '.join(SYSTEMS)} or a mapping of length, mass, time, "
                             f"got {units!r}")
        return SYSTEMS[key]
    if hasattr(units, "keys"):
        given = dict(units)
        missing = [k for k in ("length", "mass", "time") if not isinstance(given.get(k), str) or not given.get(k)]
        if missing:
            raise ValueError(f"{name}: expected a mapping with unit names (strings) for length, mass and time, "
                             f"got {given!r} (missing or not a string: {', '.join(missing)})")
        unknown = set(given) - set(Units._fields)
        if unknown:
            raise ValueError(f"{name}: expected keys among {', '.join(Units._fields)}, got {sorted(unknown)}")
        for key in ("length_si", "mass_si", "time_si", "force_si"):
            value = given.get(key)
            if value is not None:
                if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0 \
                        or value == float("inf"):
                    raise ValueError(f"{name}: expected a positive number for {key}, got {value!r}")
                given[key] = float(value)
        if given.get("symbols") is not None:
            symbols = tuple(given["symbols"])
            if len(symbols) != 3 or not all(isinstance(s, str) and s for s in symbols):
                raise ValueError(f"{name}: expected symbols as three strings (length, mass, time), got "
                                 f"{given['symbols']!r}")
            given["symbols"] = symbols
        if given.get("force_si") is not None and not given.get("force"):
            raise ValueError(f"{name}: expected the name of the force unit (force) with force_si, got {given!r}")
        given["gravity"] = bool(given.get("gravity", False))
        return Units(**given)
    raise TypeError(f"{name}: expected a cg.Units, a system name ({', '.join(SYSTEMS)}), a mapping of length, "
                    f"mass, time, or None, got {type(units).__name__}")


def dimension(field, dim=3):
    """Exponents (mass, length, time) of ``field`` in ``dim`` dimensions (densities are per D-volume)."""
    d = DIMENSIONS.get(field) or QUANTITIES.get(field)
    if d is None:
        raise ValueError(f"field: no dimension known for {field!r}; known: {', '.join(DIMENSIONS)}, "
                         f"{', '.join(QUANTITIES)}")
    if dim not in (2, 3):
        raise ValueError(f"dim: expected 2 or 3, got {dim!r}")
    return d.mass, d.length - (dim if d.per_volume else 0), d.time


def _made_of(field):
    return DIMENSIONS[field].made_of if field in DIMENSIONS else ""


def check_fields(units, fields, name="fields"):
    """Refuse fields that add kinetic and contact stresses when ``units`` makes them incommensurate."""
    units = as_units(units)
    if units is None or units.consistent:
        return
    mixed = [f for f in fields if f in DIMENSIONS and DIMENSIONS[f].made_of == "mixed"]
    if mixed:
        raise ValueError(f"{name}: {', '.join(mixed)} add(s) kinetic stress (in {units.mass} {units.length}^2 "
                         f"{units.time}^-2 per volume) to contact stress (in {units.force} {units.length} per "
                         f"volume), which {units.name or 'these'} units do not make commensurate; request "
                         f"kinetic_stress and contact_stress separately, or use consistent units")


_SUPERSCRIPTS = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def _exponent_text(exponent, pretty):
    if exponent.denominator == 1:
        e = str(exponent.numerator)
        return e.translate(_SUPERSCRIPTS) if pretty else "^" + e
    return f"^({exponent})"


def _compose(factors, pretty):
    """Text of a product of (symbol, Fraction exponent): "kg m^-1 s^-2" (plain) or "kg / (m s²)" (pretty).
    A unit name with a slash (g/mol) is put in parentheses when anything multiplies it."""
    factors = [(s, e) for s, e in factors if e != 0]
    if not factors:
        return "1"
    if len(factors) > 1 or factors[0][1] != 1:
        factors = [(f"({s})" if "/" in s and not s.startswith("√") else s, e) for s, e in factors]
    if not pretty:
        return " ".join(s if e == 1 else f"{s}{_exponent_text(e, False)}" for s, e in factors)

    def powers(items):
        roots = [s for s, e in items if e == Fraction(1, 2)]
        out = [s if e == 1 else f"{s}{_exponent_text(e, True)}" for s, e in items if e != Fraction(1, 2)]
        if roots:
            out.append(f"√{roots[0]}" if len(roots) == 1 else "√(" + " ".join(roots) + ")")
        return out
    num = " ".join(powers([(s, e) for s, e in factors if e > 0]))
    den = powers([(s, -e) for s, e in factors if e < 0])
    if not den:
        return num
    den_text = den[0] if len(den) == 1 else "(" + " ".join(den) + ")"
    return f"{num or '1'} / {den_text}"


def unit(field, units, dim=3, pretty=False):
    """The unit of ``field`` in ``units`` as text, or None when the units are not known.

    ``pretty=False`` gives the CF-style text written to files (``"kg m^-1 s^-2"``); ``pretty=True``
    the one plot labels use (``"kg / (m s²)"``, ``"m g / d²"``). In units whose force is not
    mass x length / time^2 (LAMMPS ``real``, ``metal``), a field made of forces is written in the
    force unit (``"eV/Angstrom Angstrom^-2"``), and a field that adds both kinds raises ValueError.
    """
    units = as_units(units)
    if units is None:
        return None
    m, length, t = dimension(field, dim)
    names = units.symbols if (pretty and units.symbols) else (units.length, units.mass, units.time)
    sym_l, sym_m, sym_t = names
    made_of = _made_of(field)
    if not units.consistent and made_of in ("force", "mixed"):
        if made_of == "mixed":
            check_fields(units, (field,), "field")
        # force x length^(L - 1): the mass and time exponents are those of one force
        return _compose([(units.force, Fraction(1)), (sym_l, Fraction(length - 1))], pretty)
    if units.gravity:
        # time = √(length / g): time^t = length^(t/2) g^(-t/2)
        return _compose([(sym_m, Fraction(m)), ("g", Fraction(-t, 2)), (sym_l, Fraction(length) + Fraction(t, 2))],
                        pretty)
    return _compose([(sym_m, Fraction(m)), (sym_l, Fraction(length)), (sym_t, Fraction(t))], pretty)


def to_si(field, units, dim=3):
    """The factor that converts ``field`` from ``units`` to SI (None for reduced units such as ``lj``)."""
    units = as_units(units)
    if units is None or units.length_si is None or units.mass_si is None or units.time_si is None:
        return None
    m, length, t = dimension(field, dim)
    made_of = _made_of(field)
    if not units.consistent and made_of in ("force", "mixed"):
        if made_of == "mixed":
            check_fields(units, (field,), "field")
        return units.force_si * units.length_si ** (length - 1)
    return units.mass_si ** m * units.length_si ** length * units.time_si ** t


def label_units(field, units, dim=3):
    """The bracketed part of a plot label: ``"[kg / (m s²)]"``, or ``"(simulation units)"``."""
    text = unit(field, units, dim, pretty=True)
    if text is None:
        return f"({SIMULATION_UNITS})"
    return f"[{text}]"
