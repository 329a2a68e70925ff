"""Bad input gets a clear error (docs/theory.md, "Hard cases and bad input"), raised before any work.

Every case is (call, exception type, regex): the message must start with the
argument's name and say what was expected. An autouse fixture replaces the C
core's scatter functions (as seen by the coarse-graining and residual modules)
by ones that raise AssertionError, so a case that started computing before
failing shows up as an AssertionError instead of the expected exception.
"""
import re

import numpy as np
import pytest

import cgbound
import cgbound as cg
from helpers import ForbiddenCore

N, D = 5, 3
RNG = np.random.default_rng(12)
POS = RNG.uniform(0.2, 1.8, (N, D))
VEL = RNG.normal(size=(N, D))
MASS = RNG.uniform(0.5, 2.0, N)
FIXED = np.array([False, False, False, False, True])
SPECIES = np.array([0, 1, 0, 1, 0])
RADII = RNG.uniform(0.1, 0.3, N)
GRAVITY = np.array([0.0, 0.0, -1.0])
CI, CJ = np.array([0, 1, 2]), np.array([1, 4, -1])
CF = RNG.normal(size=(3, D))
CP = np.array([0.5 * (POS[0] + POS[1]), 0.5 * (POS[1] + POS[4]), POS[2] + [0.0, 0.0, -0.1]])


def box(**kw):
    return cg.Box(kw.get("lower", [0.0, 0.0, 0.0]), kw.get("upper", [2.0, 2.0, 2.0]),
                  kw.get("periodic", (True, True, False)))


def contacts(**kw):
    return cg.Contacts(kw.get("i", CI), kw.get("j", CJ), kw.get("force", CF), kw.get("point", CP))


def snapshot(**kw):
    args = dict(positions=POS, velocities=VEL, masses=MASS, box=box(), contacts=contacts(), fixed=FIXED,
                species=SPECIES, body_force=GRAVITY, radii=RADII, time=1.5)
    args.update(kw)
    return cg.Snapshot(**args)


def grid():
    return cg.Grid(box(), (3, 3, 4))


SNAP = snapshot()
PTS = np.array([[1.0, 1.0, 1.0], [0.5, 1.5, 0.7]])


@pytest.fixture(autouse=True)
def no_work(monkeypatch):
    monkeypatch.setattr(cgbound._engine, "_core", ForbiddenCore(cgbound._engine._core))


def test_the_forbidden_core_catches_work():
    """The fixture really stops good input: otherwise the matrix below would prove nothing."""
    with pytest.raises(AssertionError, match="ran before"):
        cg.coarse_grain(SNAP, grid(), cg.Lucy(0.8))
    with pytest.raises(AssertionError, match="ran before"):
        cg.CoarseGrain([SNAP], grid(), cg.Lucy(0.8)).run()
    with pytest.raises(AssertionError, match="ran before"):
        cg.momentum_balance_residual(SNAP, PTS, cg.Lucy(0.8))


# --- generic families of bad values ------------------------------------------------------------

def _bad_reals(good, nan_ok_shape=True):
    """(label, value, exception, message regex after the name) for a real-valued array argument."""
    good = np.asarray(good, dtype=float)
    obj_none = good.astype(object)
    obj_none.flat[0] = None
    obj_dict = good.astype(object)
    obj_dict.flat[-1] = {"x": 1}
    out = [
        ("none", None, TypeError, "expected an array of real numbers, got None"),
        ("strings", np.full(good.shape, "a"), TypeError, "expected real numbers, got dtype <U1"),
        ("numeric-strings", good.astype(str), TypeError, "expected real numbers, got dtype <U"),
        ("bytes", good.astype(bytes), TypeError, "expected real numbers, got dtype \\|S"),
        ("object-none", obj_none, TypeError, "expected real numbers, got None at index"),
        ("object-dict", obj_dict, TypeError, "expected real numbers, got \\{'x': 1\\} at index"),
        ("complex", good + 1j, TypeError, "expected real numbers, got complex"),
        ("complex-zero-imag", good.astype(complex), TypeError, "expected real numbers, got complex"),
        ("bool", np.ones(good.shape, bool), TypeError, "expected real numbers, got dtype bool"),
        ("datetime", np.zeros(good.shape, "datetime64[s]"), TypeError, "expected real numbers, got dtype datetime"),
        ("extra-axis", good[..., None], ValueError, f"expected a {good.ndim}-dimensional array, got shape"),
        ("scalar", 1.0, ValueError, f"expected a {good.ndim}-dimensional array, got shape \\(\\)"),
    ]
    for label, value in (("nan", np.nan), ("inf", np.inf), ("-inf", -np.inf)):
        bad = good.copy()
        bad.flat[-1] = value
        out.append((label, bad, ValueError, f"expected finite values, got {re.escape(str(value))} at index"))
    if good.ndim == 2:
        ragged = [list(row) for row in good]
        ragged[-1] = ragged[-1][:-1]
        out.append(("ragged", ragged, ValueError, "expected a rectangular array of real numbers, got a ragged"))
    return out


def _bad_indices(good, check_length=True):
    good = np.asarray(good)
    n = good.shape[0]
    frac = good.astype(float)
    frac[-1] += 0.5
    out = [
        ("none", None, TypeError, "expected an array of integers, got None"),
        ("strings", good.astype(str), TypeError, "expected integers, got dtype <U"),
        ("complex", good + 0j, TypeError, "expected integers, got dtype complex"),
        ("bool", np.ones(n, bool), TypeError, "expected integers, got dtype bool"),
        ("object", np.array([None] * n, dtype=object), TypeError, "expected integers, got dtype object"),
        ("2d", good[:, None], ValueError, "expected a 1-dimensional array, got shape"),
        ("fraction", frac, ValueError, "expected integral values, got .*5 at index"),
        ("huge-uint", np.full(n, 2**63 + 5, dtype=np.uint64), ValueError, "expected integers that fit in int64"),
        ("huge-float", np.full(n, 1e30), ValueError, "expected integers that fit in int64"),
    ]
    for label, value in (("nan", np.nan), ("inf", np.inf)):
        bad = good.astype(float)
        bad[0] = value
        out.append((label, bad, ValueError, "expected finite integers, got"))
    if check_length:
        out.append(("length", good[:-1], ValueError, f"expected length {n}, got {n - 1}"))
    return out


def _bad_positive(optional=False):
    out = [
        ("string", "1.0", TypeError, "expected a positive number, got '1.0'"),
        ("complex", 1 + 0j, TypeError, "expected a positive number, got \\(1\\+0j\\)"),
        ("bool", True, TypeError, "expected a positive number, got True"),
        ("list", [1.0], TypeError, "expected a positive number, got \\[1.0\\]"),
        ("zero", 0.0, ValueError, "expected a positive finite number, got 0.0"),
        ("negative", -0.5, ValueError, "expected a positive finite number, got -0.5"),
        ("nan", np.nan, ValueError, "expected a positive finite number, got nan"),
        ("inf", np.inf, ValueError, "expected a positive finite number, got inf"),
        ("-inf", -np.inf, ValueError, "expected a positive finite number, got -inf"),
    ]
    if not optional:
        out.append(("none", None, TypeError, "expected a positive number, got None"))
    return out


CASES = []


def case(id, call, exc, regex):
    CASES.append(pytest.param(call, exc, regex, id=id))


def family(prefix, name, bad_values, make):
    """Cases from a family: ``make(value)`` calls the API with one argument replaced."""
    for label, value, exc, tail in bad_values:
        case(f"{prefix}-{label}", (lambda v=value: make(v)), exc, re.escape(name) + ": " + tail)


# --- cg.Box(lower, upper, periodic) -------------------------------------------------------------

family("Box.lower", "lower", _bad_reals([0.0, 0.0, 0.0]), lambda v: box(lower=v))
family("Box.upper", "upper", [c for c in _bad_reals([2.0, 2.0, 2.0]) if c[0] not in ("extra-axis", "scalar")],
       lambda v: box(upper=v))
case("Box.upper-2d", lambda: box(upper=[[2.0, 2.0, 2.0]]), ValueError, r"upper: expected a 1-dimensional array")
case("Box.lower-1-coordinate", lambda: cg.Box([0.0], [1.0]), ValueError, r"lower: expected 2 or 3 coordinates, got 1")
case("Box.lower-4-coordinates", lambda: cg.Box([0.0] * 4, [1.0] * 4), ValueError,
     r"lower: expected 2 or 3 coordinates, got 4")
case("Box.upper-dimension-mismatch", lambda: cg.Box([0, 0, 0], [1, 1]), ValueError,
     r"upper: expected 3 coordinates like lower, got 2")
case("Box.upper-equal-lower", lambda: cg.Box([0, 0, 0], [1, 0, 1]), ValueError,
     r"upper: expected upper > lower on every axis, got lower=\[0.0, 0.0, 0.0\], upper=\[1.0, 0.0, 1.0\]")
case("Box.upper-below-lower", lambda: cg.Box([0, 0, 0], [1, 1, -1]), ValueError, r"upper: expected upper > lower")
case("Box.periodic-string", lambda: box(periodic="yes"), TypeError, r"periodic: expected a bool or 3 bools, got 'yes'")
case("Box.periodic-none", lambda: box(periodic=None), TypeError, r"periodic: expected a bool or 3 bools, got None")
case("Box.periodic-2", lambda: box(periodic=2), TypeError, r"periodic: expected True or False, got 2")
case("Box.periodic-float", lambda: box(periodic=0.5), TypeError, r"periodic: expected True or False, got 0.5")
case("Box.periodic-entry-string", lambda: box(periodic=(True, "no", False)), TypeError,
     r"periodic: expected True or False, got 'no'")
case("Box.periodic-length", lambda: box(periodic=(True, False)), ValueError,
     r"periodic: expected a bool or 3 bools, got \(True, False\)")
case("Box.periodic-2d", lambda: box(periodic=[[True, True, False]]), ValueError, r"periodic: expected a bool or 3 bools")

# --- cg.Contacts(i, j, force, point) and their checks against the snapshot ----------------------

family("Contacts.i", "contacts.i", [c for c in _bad_indices(CI, check_length=False)], lambda v: contacts(i=v))
family("Contacts.j", "contacts.j", _bad_indices(CJ), lambda v: contacts(j=v))
family("Contacts.force", "contacts.force", [c for c in _bad_reals(CF) if c[0] != "scalar"],
       lambda v: contacts(force=v))
family("Contacts.point", "contacts.point", [c for c in _bad_reals(CP) if c[0] != "scalar"],
       lambda v: contacts(point=v))
case("Contacts.force-rows", lambda: contacts(force=CF[:2]), ValueError,
     r"contacts.force: expected 3 rows like contacts.i, got 2")
case("Contacts.point-shape", lambda: contacts(point=CP[:, :2]), ValueError,
     r"contacts.point: expected shape \(3, 3\) like contacts.force, got \(3, 2\)")
case("Contacts.i-out-of-range", lambda: snapshot(contacts=contacts(i=[0, 1, 5])), IndexError,
     r"contacts.i: expected particle indices in \[0, 5\), got 5 at contact 2")
case("Contacts.i-negative", lambda: snapshot(contacts=contacts(i=[0, -1, 2])), IndexError,
     r"contacts.i: expected particle indices in \[0, 5\), got -1 at contact 1")
case("Contacts.j-out-of-range", lambda: snapshot(contacts=contacts(j=[1, 7, -1])), IndexError,
     r"contacts.j: expected particle indices in \[0, 5\) or -1 for a wall, got 7 at contact 1")
case("Contacts.j-below-wall", lambda: snapshot(contacts=contacts(j=[1, 4, -2])), IndexError,
     r"contacts.j: expected particle indices in \[0, 5\) or -1 for a wall, got -2 at contact 2")
case("Contacts.self-contact", lambda: snapshot(contacts=contacts(j=[1, 1, -1])), ValueError,
     r"contacts.j: expected a particle other than contacts.i .*got particle 1 joined to itself at contact 1")
case("Contacts.listed-twice", lambda: snapshot(contacts=contacts(i=[0, 0, 2], j=[1, 1, -1])), ValueError,
     r"contacts: expected each pair once .*got the pair \(0, 1\) at contacts 0, 1")
case("Contacts.listed-twice-reversed", lambda: snapshot(contacts=contacts(i=[0, 4, 1], j=[1, 1, 0])), ValueError,
     r"contacts: expected each pair once .*got the pair \(0, 1\) at contacts 0, 2")
case("Contacts.force-2d-in-3d-snapshot",
     lambda: snapshot(contacts=cg.Contacts(CI, CJ, CF[:, :2], CP[:, :2])), ValueError,
     r"contacts.force: expected shape \(3, 3\) for a 3D snapshot, got \(3, 2\)")
case("Snapshot.contacts-type", lambda: snapshot(contacts=(CI, CJ, CF, CP)), TypeError,
     r"contacts: expected a cg.Contacts, got tuple")

# --- cg.Snapshot(positions, velocities, masses, box, contacts, fixed, species, body_force, radii, time) -

family("Snapshot.positions", "positions", _bad_reals(POS), lambda v: snapshot(positions=v))
case("Snapshot.positions-4-columns", lambda: snapshot(positions=np.zeros((N, 4))), ValueError,
     r"positions: expected shape \(N, 2\) or \(N, 3\), got \(5, 4\)")
case("Snapshot.positions-1-column", lambda: snapshot(positions=np.zeros((N, 1))), ValueError,
     r"positions: expected shape \(N, 2\) or \(N, 3\), got \(5, 1\)")
family("Snapshot.velocities", "velocities", [c for c in _bad_reals(VEL) if c[0] != "none"],
       lambda v: snapshot(velocities=v))
case("Snapshot.velocities-rows", lambda: snapshot(velocities=VEL[:-1]), ValueError,
     r"velocities: expected shape \(5, 3\), got \(4, 3\)")
case("Snapshot.velocities-columns", lambda: snapshot(velocities=VEL[:, :2]), ValueError,
     r"velocities: expected shape \(5, 3\), got \(5, 2\)")
family("Snapshot.masses", "masses", [c for c in _bad_reals(MASS) if c[0] != "none"], lambda v: snapshot(masses=v))
case("Snapshot.masses-none", lambda: snapshot(masses=None), TypeError, r"masses: expected an array of N positive masses")
case("Snapshot.masses-length", lambda: snapshot(masses=MASS[:-1]), ValueError, r"masses: expected shape \(5,\), got \(4,\)")
case("Snapshot.masses-negative", lambda: snapshot(masses=np.where(np.arange(N) == 2, -1.0, MASS)), ValueError,
     r"masses: expected positive masses for flowing particles, got -1.0 at index 2")
case("Snapshot.masses-zero", lambda: snapshot(masses=np.where(np.arange(N) == 0, 0.0, MASS)), ValueError,
     r"masses: expected positive masses for flowing particles, got 0.0 at index 0")
case("Snapshot.box-type", lambda: snapshot(box=([0, 0, 0], [2, 2, 2])), TypeError, r"box: expected a cg.Box, got tuple")
case("Snapshot.box-dimension", lambda: snapshot(box=cg.Box([0, 0], [2, 2])), ValueError,
     r"box: expected a 3D box like positions, got 2D")
case("Snapshot.box-missing-no-particles",
     lambda: cg.Snapshot(np.zeros((0, 3)), None, np.zeros(0)), ValueError,
     r"box: expected a cg.Box when there are no particles, got None")
case("Snapshot.fixed-strings", lambda: snapshot(fixed=FIXED.astype(str)), TypeError, r"fixed: expected booleans, got dtype <U")
case("Snapshot.fixed-complex", lambda: snapshot(fixed=FIXED + 0j), TypeError, r"fixed: expected booleans, got dtype complex")
case("Snapshot.fixed-object", lambda: snapshot(fixed=np.array([None] * N)), TypeError, r"fixed: expected booleans, got dtype object")
case("Snapshot.fixed-length", lambda: snapshot(fixed=FIXED[:-1]), ValueError, r"fixed: expected shape \(5,\), got \(4,\)")
case("Snapshot.fixed-2d", lambda: snapshot(fixed=FIXED[:, None]), ValueError, r"fixed: expected shape \(5,\), got \(5, 1\)")
case("Snapshot.fixed-not-0-1", lambda: snapshot(fixed=[0, 0, 2, 0, 1]), ValueError,
     r"fixed: expected booleans \(0 or 1\), got 2 at index 2")
case("Snapshot.fixed-nan", lambda: snapshot(fixed=[0.0, 0.0, np.nan, 0.0, 1.0]), ValueError,
     r"fixed: expected booleans \(0 or 1\), got nan at index 2")
case("Snapshot.fixed-inf", lambda: snapshot(fixed=[0.0, 0.0, 0.0, np.inf, 1.0]), ValueError,
     r"fixed: expected booleans \(0 or 1\), got inf at index 3")
family("Snapshot.species", "species", [c for c in _bad_indices(SPECIES) if c[0] != "none"],
       lambda v: snapshot(species=v))
family("Snapshot.body_force", "body_force",
       [c for c in _bad_reals(GRAVITY) if c[0] not in ("none", "extra-axis", "scalar")],
       lambda v: snapshot(body_force=v))
case("Snapshot.body_force-2-components", lambda: snapshot(body_force=[0.0, -1.0]), ValueError,
     r"body_force: expected shape \(3,\) or \(5, 3\), got \(2,\)")
case("Snapshot.body_force-rows", lambda: snapshot(body_force=np.zeros((4, 3))), ValueError,
     r"body_force: expected shape \(3,\) or \(5, 3\), got \(4, 3\)")
case("Snapshot.body_force-scalar", lambda: snapshot(body_force=-9.81), ValueError,
     r"body_force: expected shape \(3,\) or \(5, 3\), got \(\)")
case("Snapshot.body_force-nan-per-particle", lambda: snapshot(body_force=np.full((N, D), np.nan)), ValueError,
     r"body_force: expected finite values, got nan at index \(0, 0\)")
family("Snapshot.radii", "radii", [c for c in _bad_reals(RADII) if c[0] != "none"], lambda v: snapshot(radii=v))
case("Snapshot.radii-length", lambda: snapshot(radii=RADII[:-1]), ValueError, r"radii: expected shape \(5,\), got \(4,\)")
case("Snapshot.radii-negative", lambda: snapshot(radii=np.where(np.arange(N) == 3, -0.1, RADII)), ValueError,
     r"radii: expected non-negative radii, got -0.1 at index 3")
for label, value, exc, tail in [("string", "0", TypeError, "expected a finite real number, got '0'"),
                                ("none", None, TypeError, "expected a finite real number, got None"),
                                ("complex", 1j, TypeError, "expected a finite real number, got 1j"),
                                ("bool", True, TypeError, "expected a finite real number, got True"),
                                ("array", np.zeros(2), TypeError, "expected a finite real number, got array"),
                                ("nan", np.nan, ValueError, "expected a finite real number, got nan"),
                                ("inf", np.inf, ValueError, "expected a finite real number, got inf"),
                                ("-inf", float("-inf"), ValueError, "expected a finite real number, got -inf")]:
    case(f"Snapshot.time-{label}", (lambda v=value: snapshot(time=v)), exc, "time: " + tail)

# --- cg.Grid(box, shape, average) and cg.Points(positions) ----------------------------------------

case("Grid.box-type", lambda: cg.Grid([[0, 0, 0], [1, 1, 1]], (2, 2, 2)), TypeError, r"box: expected a cg.Box, got list")
case("Grid.box-none", lambda: cg.Grid(None, (2, 2, 2)), TypeError, r"box: expected a cg.Box, got NoneType")
case("Grid.shape-length", lambda: cg.Grid(box(), (2, 2)), ValueError, r"shape: expected 3 positive integers \(one per axis\), got \(2, 2\)")
case("Grid.shape-float-entry", lambda: cg.Grid(box(), (2, 2.0, 2)), TypeError, r"shape: expected 3 positive integers, got \(2, 2.0, 2\)")
case("Grid.shape-fraction-entry", lambda: cg.Grid(box(), (2, 2.5, 2)), TypeError, r"shape: expected 3 positive integers")
case("Grid.shape-bool-entry", lambda: cg.Grid(box(), (2, True, 2)), TypeError, r"shape: expected 3 positive integers, got \(2, True, 2\)")
case("Grid.shape-numpy-bool-entry", lambda: cg.Grid(box(), (2, np.True_, 2)), TypeError, r"shape: expected 3 positive integers")
case("Grid.shape-string-entry", lambda: cg.Grid(box(), (2, "2", 2)), TypeError, r"shape: expected 3 positive integers")
case("Grid.shape-bool", lambda: cg.Grid(box(), True), TypeError, r"shape: expected 3 positive integers, got True")
case("Grid.shape-float", lambda: cg.Grid(box(), 4.0), TypeError, r"shape: expected 3 positive integers, got 4.0")
case("Grid.shape-string", lambda: cg.Grid(box(), "444"), TypeError, r"shape: expected 3 positive integers, got '444'")
case("Grid.shape-none", lambda: cg.Grid(box(), None), TypeError, r"shape: expected 3 positive integers, got None")
case("Grid.shape-zero", lambda: cg.Grid(box(), 0), ValueError, r"shape: expected positive node counts, got \(0, 0, 0\)")
case("Grid.shape-zero-entry", lambda: cg.Grid(box(), (2, 0, 2)), ValueError, r"shape: expected positive node counts, got \(2, 0, 2\)")
case("Grid.shape-negative-entry", lambda: cg.Grid(box(), (2, 2, -3)), ValueError, r"shape: expected positive node counts")
case("Grid.shape-averaged-axis", lambda: cg.Grid(box(), (2, 2, 2), average="z"), ValueError,
     r"shape: expected 1 node along the averaged axis z, got 2")
case("Grid.average-unknown", lambda: cg.Grid(box(), (2, 2, 1), average="w"), ValueError,
     r"average: expected axis names \('x', 'y', 'z'\) or indices, got unknown axis 'w'")
case("Grid.average-y-in-2d", lambda: cg.Grid(cg.Box([0, 0], [1, 1]), (2, 1), average="y"), ValueError,
     r"average: expected axis names \('x', 'z'\) or indices, got unknown axis 'y'")
case("Grid.average-repeated", lambda: cg.Grid(box(), (2, 2, 1), average=("z", "z")), ValueError,
     r"average: expected each axis at most once, got \('z', 'z'\)")
case("Grid.average-repeated-name-and-index", lambda: cg.Grid(box(), (1, 2, 2), average=("x", 0)), ValueError,
     r"average: expected each axis at most once")
case("Grid.average-index-out-of-range", lambda: cg.Grid(box(), (2, 2, 2), average=3), ValueError,
     r"average: expected axis indices in \[0, 3\), got 3")
case("Grid.average-negative-index", lambda: cg.Grid(box(), (2, 2, 2), average=-1), ValueError,
     r"average: expected axis indices in \[0, 3\), got -1")
case("Grid.average-bool", lambda: cg.Grid(box(), (2, 1, 2), average=True), TypeError,
     r"average: expected axis names .* or indices, got True")
case("Grid.average-float", lambda: cg.Grid(box(), (2, 1, 2), average=(1.0,)), TypeError,
     r"average: expected axis names .* or indices, got 1.0")
case("Grid.average-none", lambda: cg.Grid(box(), (2, 2, 2), average=None), TypeError,
     r"average: expected a sequence of axis names or indices, got None")
family("Points.positions", "points", _bad_reals(PTS), lambda v: cg.Points(v))
case("Points.positions-4-columns", lambda: cg.Points(np.zeros((2, 4))), ValueError,
     r"points: expected shape \(P, 2\) or \(P, 3\), got \(2, 4\)")

# --- kernels -----------------------------------------------------------------------------------

family("Gaussian.width", "width", _bad_positive(), lambda v: cg.Gaussian(v))
family("Gaussian.cutoff", "cutoff", _bad_positive(optional=True), lambda v: cg.Gaussian(0.3, cutoff=v))
case("Gaussian.default-cutoff-of-bad-width", lambda: cg.Gaussian(-1.0), ValueError, r"width: expected a positive")
case("Gaussian.normalize-unknown", lambda: cg.Gaussian(0.3, normalize="none"), ValueError,
     r"normalize: expected 'full' or 'truncated', got 'none'")
case("Gaussian.normalize-none", lambda: cg.Gaussian(0.3, normalize=None), TypeError,
     r"normalize: expected 'full' or 'truncated', got None")
case("Gaussian.normalize-array", lambda: cg.Gaussian(0.3, normalize=np.array(["full"])), TypeError,
     r"normalize: expected 'full' or 'truncated', got array")
family("Lucy.cutoff", "cutoff", _bad_positive(), lambda v: cg.Lucy(v))
family("Heaviside.radius", "radius", _bad_positive(), lambda v: cg.Heaviside(v))

# --- cg.coarse_grain(snapshot, grid, kernel, fields, convention, species) ---------------------------


def cgrain(**kw):
    args = dict(snapshot=SNAP, grid=grid(), kernel=cg.Lucy(0.8), fields=("density", "stress"),
                convention="tension", species=None)
    args.update(kw)
    return cg.coarse_grain(**args)


NO_SPECIES = snapshot(species=None)
NO_RADII = snapshot(radii=None)
# a boundary contact (particle 2 on a wall) whose contact point is the particle centre
CENTRE_POINT = snapshot(contacts=contacts(point=np.array([CP[0], CP[1], POS[2]])))

case("coarse_grain.snapshot-type", lambda: cgrain(snapshot=POS), TypeError, r"snapshot: expected a cg.Snapshot, got ndarray")
case("coarse_grain.snapshot-none", lambda: cgrain(snapshot=None), TypeError, r"snapshot: expected a cg.Snapshot, got NoneType")
case("coarse_grain.grid-2d-grid", lambda: cgrain(grid=cg.Grid(cg.Box([0, 0], [2, 2]), (2, 2))), ValueError,
     r"grid: expected a 3D grid or points like the snapshot, got a 2D Grid")
case("coarse_grain.grid-2d-points", lambda: cgrain(grid=PTS[:, :2]), ValueError,
     r"grid: expected a 3D grid or points like the snapshot, got a 2D Points")
case("coarse_grain.grid-cg-points-2d", lambda: cgrain(grid=cg.Points(PTS[:, :2])), ValueError,
     r"grid: expected a 3D grid or points like the snapshot, got a 2D Points")
family("coarse_grain.grid", "grid", [c for c in _bad_reals(PTS) if c[0] != "none"], lambda v: cgrain(grid=v))
case("coarse_grain.grid-none", lambda: cgrain(grid=None), TypeError, r"grid: expected an array of real numbers, got None")
case("coarse_grain.grid-box", lambda: cgrain(grid=box()), TypeError, r"grid: expected real numbers, got .*Box")
case("coarse_grain.kernel-type", lambda: cgrain(kernel=0.8), TypeError,
     r"kernel: expected cg.Gaussian, cg.Lucy or cg.Heaviside, got float")
case("coarse_grain.kernel-class", lambda: cgrain(kernel=cg.Lucy), TypeError,
     r"kernel: expected cg.Gaussian, cg.Lucy or cg.Heaviside, got type")
case("coarse_grain.fields-unknown", lambda: cgrain(fields=("density", "strain")), ValueError,
     r"fields: expected some of density, .*, got unknown field 'strain'")
case("coarse_grain.fields-unknown-single", lambda: cgrain(fields="Density"), ValueError,
     r"fields: expected some of .*got unknown field 'Density'")
case("coarse_grain.fields-empty", lambda: cgrain(fields=()), ValueError, r"fields: expected at least one field name, got none")
case("coarse_grain.fields-int", lambda: cgrain(fields=3), TypeError, r"fields: expected a sequence of field names, got 3")
case("coarse_grain.fields-none-entry", lambda: cgrain(fields=("density", None)), TypeError,
     r"fields: expected field names \(strings\), got None")
case("coarse_grain.fields-nested", lambda: cgrain(fields=[["density"]]), TypeError,
     r"fields: expected field names \(strings\), got \['density'\]")
case("coarse_grain.convention-unknown", lambda: cgrain(convention="tensile"), ValueError,
     r"convention: expected 'tension' .* or 'compression' .*, got 'tensile'")
case("coarse_grain.convention-none", lambda: cgrain(convention=None), TypeError,
     r"convention: expected 'tension' or 'compression', got None")
case("coarse_grain.convention-sign", lambda: cgrain(convention=-1), TypeError,
     r"convention: expected 'tension' or 'compression', got -1")
case("coarse_grain.species-without-species", lambda: cgrain(snapshot=NO_SPECIES, species=1), ValueError,
     r"species: expected None for a snapshot without a species array, got 1")
case("coarse_grain.species-string", lambda: cgrain(species="a"), TypeError, r"species: expected an integer or None, got 'a'")
case("coarse_grain.species-float", lambda: cgrain(species=1.5), TypeError, r"species: expected an integer or None, got 1.5")
case("coarse_grain.species-bool", lambda: cgrain(species=True), TypeError, r"species: expected an integer or None, got True")
case("coarse_grain.species-list", lambda: cgrain(species=[0, 1]), TypeError, r"species: expected an integer or None")
case("coarse_grain.volume_fraction-without-radii", lambda: cgrain(snapshot=NO_RADII, fields=("density", "volume_fraction")),
     ValueError, r"snapshot.radii: expected radii for the field 'volume_fraction', got None")
case("coarse_grain.extended_stress-contact-at-centre", lambda: cgrain(snapshot=CENTRE_POINT, fields=("extended_stress",)),
     ValueError, r"contacts.point: expected boundary contact points away from the particle centre .*particle 2")

# --- cg.CoarseGrain(...) and .run(start, stop, step, verbose) ------------------------------------------


def cgrun(run=(), **kw):
    args = dict(snapshots=[SNAP, snapshot(time=2.5)], grid=grid(), kernel=cg.Lucy(0.8), fields=("density", "stress"))
    args.update(kw)
    return cg.CoarseGrain(**args).run(**dict(run))


case("CoarseGrain.snapshots-int", lambda: cgrun(snapshots=5), TypeError,
     r"snapshots: expected a sequence or iterable of cg.Snapshot, got int")
case("CoarseGrain.snapshots-single", lambda: cgrun(snapshots=SNAP), TypeError,
     r"snapshots: expected a sequence or iterable of cg.Snapshot, got a single cg.Snapshot")
case("CoarseGrain.snapshots-empty", lambda: cgrun(snapshots=[]), ValueError,
     r"snapshots: expected at least one snapshot, got an empty sequence")
case("CoarseGrain.snapshots-frame-type", lambda: cgrun(snapshots=[POS]), TypeError,
     r"frame 0: snapshot: expected a cg.Snapshot, got ndarray")
case("CoarseGrain.grid-nan", lambda: cgrun(grid=np.full((2, 3), np.nan)), ValueError, r"grid: expected finite values, got nan")
case("CoarseGrain.grid-strings", lambda: cgrun(grid="grid"), TypeError, r"grid: expected real numbers, got dtype <U")
case("CoarseGrain.grid-dimension", lambda: cgrun(grid=PTS[:, :2]), ValueError,
     r"frame 0: grid: expected a 3D grid or points like the snapshot, got a 2D Points")
case("CoarseGrain.kernel-type", lambda: cgrun(kernel="lucy"), TypeError, r"kernel: expected cg.Gaussian, cg.Lucy or cg.Heaviside")
case("CoarseGrain.fields-unknown", lambda: cgrun(fields=("pressure", "presure")), ValueError,
     r"fields: expected some of .*got unknown field 'presure'")
case("CoarseGrain.convention-unknown", lambda: cgrun(convention="Tension"), ValueError, r"convention: expected 'tension'")
case("CoarseGrain.species-string", lambda: cgrun(species="0"), TypeError, r"species: expected an integer or None, got '0'")
case("CoarseGrain.species-without-species", lambda: cgrun(snapshots=[NO_SPECIES], species=0), ValueError,
     r"frame 0: species: expected None for a snapshot without a species array, got 0")
case("CoarseGrain.volume_fraction-without-radii", lambda: cgrun(snapshots=[NO_RADII], fields=("volume_fraction",)),
     ValueError, r"frame 0: snapshot.radii: expected radii for the field 'volume_fraction', got None")
case("CoarseGrain.time_average-unknown", lambda: cgrun(time_average="median"), ValueError,
     r"time_average: expected 'mean', 'none' or a positive width, got 'median'")
case("CoarseGrain.time_average-negative", lambda: cgrun(time_average=-1.0), ValueError,
     r"time_average: expected a positive finite number, got -1.0")
case("CoarseGrain.time_average-nan", lambda: cgrun(time_average=np.nan), ValueError,
     r"time_average: expected a positive finite number, got nan")
case("CoarseGrain.time_average-bool", lambda: cgrun(time_average=True), TypeError,
     r"time_average: expected a positive number, got True")
case("CoarseGrain.time_average-none", lambda: cgrun(time_average=None), TypeError,
     r"time_average: expected a positive number, got None")
family("CoarseGrain.times", "times", [c for c in _bad_reals([1.0, 2.0]) if c[0] not in ("none", "object-none")],
       lambda v: cgrun(time_average=0.5, times=v))
case("CoarseGrain.times-without-smoothing", lambda: cgrun(times=[1.0, 2.0]), ValueError,
     r"times: expected None unless time_average is a width .*, got times with time_average='mean'")
for arg in ("start", "stop", "step"):
    case(f"run.{arg}-string", (lambda a=arg: cgrun(run={a: "1"})), TypeError, f"{arg}: expected an integer or None, got '1'")
    case(f"run.{arg}-float", (lambda a=arg: cgrun(run={a: 1.0})), TypeError, f"{arg}: expected an integer or None, got 1.0")
    case(f"run.{arg}-bool", (lambda a=arg: cgrun(run={a: True})), TypeError, f"{arg}: expected an integer or None, got True")
case("run.step-zero", lambda: cgrun(run={"step": 0}), ValueError, r"step: expected a non-zero integer or None, got 0")
case("run.empty-selection", lambda: cgrun(run={"start": 5}), ValueError,
     r"start, stop, step: expected a selection of at least one frame, got none")
case("run.negative-start-on-iterator", lambda: cgrun(snapshots=iter([SNAP]), run={"start": -1}), ValueError,
     r"start, stop, step: expected values >= 0 for snapshots without len\(\)")
case("run.verbose-string", lambda: cgrun(run={"verbose": "yes"}), TypeError, r"verbose: expected True or False, got 'yes'")
case("run.verbose-none", lambda: cgrun(run={"verbose": None}), TypeError, r"verbose: expected True or False, got None")

# --- cg.momentum_balance_residual(snapshot, points, kernel, forces) -----------------------------------


def residual(**kw):
    args = dict(snapshot=SNAP, points=PTS, kernel=cg.Lucy(0.8), forces=None)
    args.update(kw)
    return cg.momentum_balance_residual(**args)


case("residual.snapshot-type", lambda: residual(snapshot="snap"), TypeError, r"snapshot: expected a cg.Snapshot, got str")
family("residual.points", "points", _bad_reals(PTS), lambda v: residual(points=v))
case("residual.points-dimension", lambda: residual(points=PTS[:, :2]), ValueError,
     r"points: expected a 3D grid or points like the snapshot, got a 2D Points")
case("residual.points-grid", lambda: residual(points=grid()), TypeError,
     r"points: expected cg.Points or a \(P, D\) array .*got Grid")
case("residual.kernel-heaviside", lambda: residual(kernel=cg.Heaviside(0.8)), ValueError,
     r"kernel: expected a differentiable kernel \(Gaussian or Lucy\) .*got Heaviside")
case("residual.kernel-none", lambda: residual(kernel=None), TypeError, r"kernel: expected cg.Gaussian, cg.Lucy or cg.Heaviside")
family("residual.forces", "forces", [c for c in _bad_reals(VEL) if c[0] != "none"], lambda v: residual(forces=v))
case("residual.forces-rows", lambda: residual(forces=VEL[:-1]), ValueError, r"forces: expected shape \(5, 3\), got \(4, 3\)")
case("residual.forces-columns", lambda: residual(forces=VEL[:, :2]), ValueError, r"forces: expected shape \(5, 3\), got \(5, 2\)")


@pytest.mark.parametrize("call, exc, regex", CASES)
def test_bad_input(call, exc, regex):
    with pytest.raises(exc) as info:
        call()
    assert info.type is exc, f"expected exactly {exc.__name__}, got {info.type.__name__}: {info.value}"
    message = str(info.value)
    assert re.search(regex, message), f"message {message!r} does not match {regex!r}"
    # the argument is named first (CoarseGrain.run prefixes the frame), in the style "<argument>: expected ..."
    assert re.match(r"(frame \d+: )?[\w., ]+: expected ", message), message


def test_case_count():
    assert len(CASES) >= 300
