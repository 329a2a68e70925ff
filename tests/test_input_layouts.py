"""Any reasonable memory layout or dtype of an array argument is accepted, gives the same result, and is not modified.

Each case swaps one array argument (or all of them) for a float32, strided,
Fortran-ordered, read-only or plain-list version (integer arguments: other
integer widths, unsigned, integral floats; ``fixed``: 0/1 numbers) and compares
every output of coarse_grain, CoarseGrain.run and momentum_balance_residual
exactly (np.array_equal) with the run on float64 C-ordered arrays holding the
same values (for float32: the float64 arrays converted from the float32 ones).
"""
import copy

import numpy as np
import pytest

import cgbound as cg
from helpers import random_snapshot

FIELDS = ("density", "momentum", "velocity", "kinetic_stress", "contact_stress", "boundary_stress", "stress",
          "extended_stress", "interaction_force_density", "body_force_density", "volume_fraction", "temperature")


def base_arrays():
    snap = random_snapshot(5, dim=3)
    rng = np.random.default_rng(5)
    c = snap.contacts
    n = snap.n_particles
    return {
        "positions": np.array(snap.positions), "velocities": np.array(snap.velocities),
        "masses": np.array(snap.masses), "fixed": np.array(snap.fixed),
        "species": rng.integers(0, 2, n), "body_force": np.array(snap.body_force[0]),
        "body_force_per_particle": np.array(snap.body_force) * rng.uniform(0.5, 1.5, (n, 1)),
        "radii": np.array(snap.radii),
        "contacts.i": np.array(c.i), "contacts.j": np.array(c.j),
        "contacts.force": np.array(c.force), "contacts.point": np.array(c.point),
        "lower": np.array(snap.box.lower), "upper": np.array(snap.box.upper),
        "points": rng.uniform(snap.box.lower, snap.box.upper, (7, 3)),
        "forces": rng.normal(size=(n, 3)),
        "times": np.array([3.0, 4.5, 6.0]),
        "_periodic": snap.box.periodic, "_time": snap.time,
    }


BASE = base_arrays()
REALS_1D = ("masses", "body_force", "radii", "lower", "upper", "times")
REALS_2D = ("positions", "velocities", "body_force_per_particle", "contacts.force", "contacts.point", "points", "forces")
INDICES = ("contacts.i", "contacts.j", "species")


def compute(a):
    """Every output for the arrays a (same keys as BASE), as a flat dict of arrays."""
    box = cg.Box(a["lower"], a["upper"], periodic=a["_periodic"])
    contacts = cg.Contacts(a["contacts.i"], a["contacts.j"], a["contacts.force"], a["contacts.point"])
    common = dict(box=box, contacts=contacts, fixed=a["fixed"], species=a["species"], radii=a["radii"])
    snap = cg.Snapshot(a["positions"], a["velocities"], a["masses"], body_force=a["body_force"], time=a["_time"],
                       **common)
    snap2 = cg.Snapshot(a["positions"], a["velocities"], a["masses"], body_force=a["body_force_per_particle"],
                        time=a["_time"] + 1.0, **common)
    grid = cg.Grid(box, (3, 3, 4))
    kernel = cg.Lucy(1.2)
    out = {}

    def put(prefix, result):
        for name in result.fields:
            out[f"{prefix}.{name}"] = np.array(result[name])

    put("grid", cg.coarse_grain(snap, grid, kernel, fields=FIELDS))
    put("points", cg.coarse_grain(snap2, a["points"], kernel, fields=FIELDS))
    put("species", cg.coarse_grain(snap, grid, kernel, fields=("density", "stress", "interaction_force_density"),
                                   species=1))
    put("run", cg.CoarseGrain([snap, snap2], grid, kernel, fields=FIELDS).run().results)
    put("smooth", cg.CoarseGrain([snap, snap2], a["points"], kernel, fields=("density", "momentum"),
                                 time_average=0.7, times=a["times"]).run().results)
    for label, forces in (("built", None), ("given", a["forces"])):
        balance = cg.momentum_balance_residual(snap2, a["points"], kernel, forces=forces)
        for term in ("residual", "forcing", "div_contact_stress", "div_boundary_stress",
                     "interaction_force_density", "body_force_density"):
            out[f"balance-{label}.{term}"] = np.array(getattr(balance, term))
    return out


REFERENCE = compute(BASE)


def _strided(arr):
    """A non-contiguous view holding arr's values (every other element along every axis)."""
    big = np.zeros(tuple(2 * s + 1 for s in arr.shape), dtype=arr.dtype)
    view = big[tuple(slice(1, None, 2) for _ in arr.shape)]
    view[...] = arr
    assert not view.flags.c_contiguous or arr.size <= 1
    return view


def _readonly(arr):
    out = arr.copy()
    out.setflags(write=False)
    return out


def _same(x):
    return x


REAL_LAYOUTS = {
    "float32": (lambda x: x.astype(np.float32), lambda x: x.astype(np.float32).astype(np.float64)),
    "strided": (_strided, _same),
    "fortran": (np.asfortranarray, _same),
    "readonly": (_readonly, _same),
    "list": (lambda x: x.tolist(), _same),
    "reversed-view": (lambda x: x[::-1].copy()[::-1], _same),
}
INDEX_LAYOUTS = {
    "int32": (lambda x: x.astype(np.int32), _same),
    "int16": (lambda x: x.astype(np.int16), _same),
    "uint32": (lambda x: x.astype(np.uint32), _same),
    "uint64": (lambda x: x.astype(np.uint64), _same),
    "float-integral": (lambda x: x.astype(np.float64), _same),
    "float32-integral": (lambda x: x.astype(np.float32), _same),
    "strided": (_strided, _same),
    "readonly": (_readonly, _same),
    "list": (lambda x: x.tolist(), _same),
}
FIXED_LAYOUTS = {
    "int-0-1": (lambda x: x.astype(np.int64), _same),
    "int8-0-1": (lambda x: x.astype(np.int8), _same),
    "uint8-0-1": (lambda x: x.astype(np.uint8), _same),
    "float-0-1": (lambda x: x.astype(np.float64), _same),
    "list-of-bools": (lambda x: x.tolist(), _same),
    "list-of-0-1": (lambda x: x.astype(int).tolist(), _same),
    "strided": (_strided, _same),
    "readonly": (_readonly, _same),
}


def _cases():
    cases = []
    for name in REALS_1D + REALS_2D:
        for layout, funcs in REAL_LAYOUTS.items():
            if layout == "fortran" and name in REALS_1D:
                continue  # a 1-D array is both C and Fortran ordered
            cases.append(pytest.param(name, funcs, id=f"{name}-{layout}"))
    for name in INDICES:
        for layout, funcs in INDEX_LAYOUTS.items():
            if layout.startswith("uint") and np.any(BASE[name] < 0):
                continue  # contacts.j holds -1 for walls
            cases.append(pytest.param(name, funcs, id=f"{name}-{layout}"))
    for layout, funcs in FIXED_LAYOUTS.items():
        cases.append(pytest.param("fixed", funcs, id=f"fixed-{layout}"))
    return cases


CASES = _cases()


def _equal(a, b):
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(np.asarray(a), np.asarray(b), equal_nan=np.asarray(a).dtype.kind == "f")
    return a == b


def _check_results(arrays, expected_arrays):
    given_copy = copy.deepcopy(arrays)
    got = compute(arrays)
    for key, value in arrays.items():
        assert type(value) is type(given_copy[key]) and _equal(value, given_copy[key]), f"{key} was modified"
        if isinstance(value, np.ndarray):
            assert value.dtype == given_copy[key].dtype and value.shape == given_copy[key].shape
    expected = REFERENCE if expected_arrays is None else compute(expected_arrays)
    assert got.keys() == expected.keys()
    for key in expected:
        assert got[key].shape == expected[key].shape, key
        assert np.array_equal(got[key], expected[key], equal_nan=True), f"{key} differs"
    return got


@pytest.mark.parametrize("name, funcs", CASES)
def test_layout_gives_same_result(name, funcs):
    given, expected_values = funcs
    arrays = dict(BASE)
    arrays[name] = given(BASE[name])
    expected = None
    if expected_values is not _same:
        expected = dict(BASE)
        expected[name] = expected_values(BASE[name])
    _check_results(arrays, expected)


@pytest.mark.parametrize("layout", sorted(set(REAL_LAYOUTS) | {"readonly", "strided", "list"}))
def test_all_arguments_in_one_layout(layout):
    """Every argument at once in the layout (index and fixed arrays in their nearest equivalent)."""
    arrays = dict(BASE)
    expected = dict(BASE)
    real = REAL_LAYOUTS[layout]
    index = INDEX_LAYOUTS.get(layout, INDEX_LAYOUTS["int32"])
    fixed = FIXED_LAYOUTS.get(layout, FIXED_LAYOUTS["int-0-1"])
    for name in REALS_1D + REALS_2D:
        arrays[name], expected[name] = real[0](BASE[name]), real[1](BASE[name])
    for name in INDICES:
        arrays[name] = index[0](BASE[name])
    arrays["fixed"] = fixed[0](BASE["fixed"])
    _check_results(arrays, None if real[1] is _same else expected)


def test_float32_really_differs_from_float64():
    """The float32 cases are not vacuous: rounding to float32 changes the fields."""
    arrays = dict(BASE)
    arrays["positions"] = BASE["positions"].astype(np.float32).astype(np.float64)
    got = compute(arrays)
    assert not np.array_equal(got["grid.density"], REFERENCE["grid.density"])


def test_arrays_stored_by_the_classes_are_private_copies():
    """Changing an input after construction does not change the snapshot (and vice versa is impossible)."""
    pos = BASE["positions"].copy()
    snap = cg.Snapshot(pos, None, BASE["masses"], box=cg.Box(BASE["lower"], BASE["upper"]))
    pos[0, 0] += 100.0
    assert snap.positions[0, 0] == BASE["positions"][0, 0]
    assert not snap.positions.flags.writeable
    assert snap.positions.dtype == np.float64 and snap.positions.flags.c_contiguous


def test_layout_case_count():
    assert len(CASES) >= 100
