"""Hostile calls of the public API, shared by tests/test_adversarial_api.py (bounded) and tools/fuzz_api.py (long).

Every call either gives a finite, correct result (checked against a cheap identity where there is one)
or raises, before any work, a ValueError / TypeError / MemoryError / IndexError whose message starts
with the name of the user's argument — never a NumPy or C internal message, never NaN or inf where
the documentation promises finite values.
"""
import math
import os
import re
import tempfile

import numpy as np
from hypothesis import strategies as st

import cgbound as cg

NAMED = (ValueError, TypeError, MemoryError, IndexError)

#: names the core's binding gives its own arrays: a message naming one of them reached the user unchecked
INTERNAL_NAMES = ("values", "vectors", "target", "node_velocity", "starts", "kernel tuple", "out", "tensors")

#: every argument name the public API may name in a message (also "a.b" forms such as contacts.force)
PUBLIC_NAMES = {
    "lower", "upper", "periodic", "positions", "velocities", "masses", "box", "contacts", "fixed", "species",
    "body_force", "radii", "time", "contacts.i", "contacts.j", "contacts.force", "contacts.point", "i", "j",
    "force", "point", "shape", "average", "width", "cutoff", "normalize", "line_quadrature", "radius", "averaged_axes",
    "snapshot", "snapshots", "grid", "points", "kernel", "fields", "convention", "forces", "path", "frame",
    "result", "time_average", "times", "provenance",
}

# ---------------------------------------------------------------- hostile scalars and arrays
EXTREME_FLOATS = [0.0, -0.0, 1.0, -1.0, 5e-324, 2.2e-308, 1e-200, 1e-104, 1e-61, 1e-60, 1e-30, 1e-9, 0.1, 0.5,
                  2.0, 1e9, 1e20, 1e30, 1e60, 1e61, 1e104, 1e154, 1e200, 1.7e308, -1e308, math.nan, math.inf,
                  -math.inf]
WEIRD = [None, "1.0", b"1", "x", True, False, 1 + 2j, [], [[]], {}, object(), np.float32(0.5), np.int8(3),
         10 ** 400, -(10 ** 400), 2 ** 63, np.array(0.5), np.array([np.nan]), np.datetime64("2020-01-01")]

scalars = st.one_of(st.sampled_from(EXTREME_FLOATS), st.sampled_from(WEIRD),
                    st.floats(allow_nan=True, allow_infinity=True, width=64),
                    st.integers(min_value=-(10 ** 30), max_value=10 ** 30))

magnitudes = st.sampled_from([1e-300, 1e-150, 1e-60, 1e-20, 1e-6, 1.0, 1e6, 1e20, 1e60, 1e150, 1e300])


def hostile_array(draw, shape):
    """An array of ``shape`` (or a mangled variant) from a hostile mix of values and dtypes."""
    kind = draw(st.sampled_from(["good", "scaled", "special", "dtype", "shape", "object", "empty"]))
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    base = rng.uniform(-1, 1, shape)
    if kind == "good":
        return base
    if kind == "scaled":
        return base * draw(magnitudes)
    if kind == "special":
        out = base.copy()
        if out.size:
            out.flat[draw(st.integers(0, out.size - 1))] = draw(st.sampled_from(EXTREME_FLOATS))
        return out
    if kind == "dtype":
        dtype = draw(st.sampled_from(["f4", "f2", "i8", "u1", "c16", "U3", "?", "M8[s]", "O"]))
        try:
            return base.astype(dtype)
        except (TypeError, ValueError):
            return base.astype("U3")
    if kind == "shape":
        new = tuple(max(0, n + draw(st.integers(-1, 1))) for n in shape) + tuple(
            draw(st.lists(st.integers(1, 2), max_size=1)))
        return rng.uniform(-1, 1, new)
    if kind == "object":
        out = base.astype(object)
        if out.size:
            out.flat[0] = draw(st.sampled_from(WEIRD))
        return out
    return np.zeros((0,) + tuple(shape[1:]))


# ---------------------------------------------------------------- assertions
def assert_named(exc, allowed=None):
    """``exc`` is one of the API's exception types and names a public argument first."""
    assert isinstance(exc, NAMED), f"{type(exc).__name__}: {exc}"
    message = str(exc)
    head = message.split(":", 1)[0].strip()
    # "frame 3: x: ..." names the frame, then the argument
    if re.fullmatch(r"frame \d+", head):
        head = message.split(":", 2)[1].strip()
    # "snapshot.radii": an attribute of the user's snapshot argument
    names = {re.sub(r"^snapshot\.", "", h.strip()) for h in head.split(",")}
    assert names and names <= (PUBLIC_NAMES if allowed is None else set(allowed) | PUBLIC_NAMES), \
        f"{type(exc).__name__} does not name a public argument: {message!r}"
    for internal in INTERNAL_NAMES:
        assert not message.startswith(internal + ":"), f"internal name in {message!r}"
    assert "numpy" not in message.lower() or "np." in message, f"NumPy message leaked: {message!r}"


#: calls made and named exceptions seen (tools/fuzz_api.py reports them: written at exit to the file
#: named by CGBOUND_FUZZ_COUNTS)
COUNTS = {"calls": 0, "named_errors": 0}


def _write_counts():
    with open(os.environ["CGBOUND_FUZZ_COUNTS"], "w") as f:
        f.write(f"{COUNTS['calls']} {COUNTS['named_errors']}\n")


if os.environ.get("CGBOUND_FUZZ_COUNTS"):
    import atexit
    atexit.register(_write_counts)


def call(fn, *args, **kwargs):
    """``fn(*args, **kwargs)``, or the exception it raised (checked to be named); None means it raised."""
    COUNTS["calls"] += 1
    try:
        return fn(*args, **kwargs), None
    except NAMED as exc:
        COUNTS["named_errors"] += 1
        assert_named(exc)
        return None, exc


# ---------------------------------------------------------------- building blocks with one hostile argument
def base_box(dim, periodic=False):
    return cg.Box(np.zeros(dim), np.ones(dim), periodic=periodic)


@st.composite
def box_case(draw):
    dim = draw(st.sampled_from([2, 3]))
    which = draw(st.sampled_from(["lower", "upper", "periodic", "none"]))
    lower, upper, periodic = np.zeros(dim), np.ones(dim) * draw(magnitudes), draw(st.booleans())
    if which == "lower":
        lower = draw(st.one_of(scalars, st.builds(lambda: None).map(lambda _: hostile_array(draw, (dim,)))))
    elif which == "upper":
        upper = hostile_array(draw, (dim,))
    elif which == "periodic":
        periodic = draw(st.one_of(scalars, st.lists(st.one_of(st.booleans(), scalars), max_size=4)))
    return lower, upper, periodic


def check_box(case):
    lower, upper, periodic = case
    box, exc = call(cg.Box, lower, upper, periodic=periodic)
    if box is not None:
        assert np.all(np.isfinite(box.lengths)) and np.all(box.lengths > 0)
    return box


@st.composite
def snapshot_case(draw):
    """Keyword arguments of a Snapshot, one or two of them hostile."""
    dim = draw(st.sampled_from([2, 3]))
    n = draw(st.integers(0, 5))
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    scale = draw(magnitudes)
    periodic = draw(st.booleans())
    box = cg.Box(np.zeros(dim), np.full(dim, scale), periodic=periodic)
    kw = dict(positions=rng.uniform(0, scale, (n, dim)), velocities=rng.normal(size=(n, dim)) * draw(magnitudes),
              masses=rng.uniform(0.5, 2.0, n) * draw(magnitudes), box=box)
    if n >= 2 and draw(st.booleans()):
        m = draw(st.integers(1, 4))
        i = rng.integers(0, n, m)
        j = (i + 1 + rng.integers(0, n - 1, m)) % n
        if draw(st.booleans()):
            j[0] = -1
        kw["contacts"] = cg.Contacts(i, j, rng.normal(size=(m, dim)) * draw(magnitudes),
                                     kw["positions"][i] * 0.5 + kw["positions"][np.maximum(j, 0)] * 0.5)
    if draw(st.booleans()):
        kw["fixed"] = rng.random(n) < 0.3
    if draw(st.booleans()):
        kw["radii"] = rng.uniform(0, 0.1, n) * scale
    if draw(st.booleans()):
        kw["body_force"] = rng.normal(size=dim)
    if draw(st.booleans()):
        kw["species"] = rng.integers(0, 2, n)
    for _ in range(draw(st.integers(0, 2))):
        name = draw(st.sampled_from(["positions", "velocities", "masses", "box", "fixed", "species", "body_force",
                                     "radii", "time", "contacts"]))
        if name in ("positions", "velocities"):
            kw[name] = hostile_array(draw, (n, dim))
        elif name in ("masses", "fixed", "species", "radii"):
            kw[name] = hostile_array(draw, (n,))
        elif name == "body_force":
            kw[name] = hostile_array(draw, (dim,))
        else:
            kw[name] = draw(scalars)
    return kw


def make_snapshot(kw):
    snap, _ = call(cg.Snapshot, **kw)
    return snap


@st.composite
def contacts_case(draw):
    m = draw(st.integers(0, 4))
    dim = draw(st.sampled_from([2, 3]))
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    args = [rng.integers(0, 3, m), rng.integers(-1, 3, m), rng.normal(size=(m, dim)), rng.normal(size=(m, dim))]
    k = draw(st.integers(0, 3))
    args[k] = draw(st.one_of(scalars, st.just(None).map(lambda _: hostile_array(draw, (m,) if k < 2 else (m, dim)))))
    return args


@st.composite
def kernel_case(draw):
    kind = draw(st.sampled_from(["Gaussian", "Lucy", "Heaviside"]))
    length = draw(st.one_of(magnitudes, scalars))
    if kind == "Gaussian":
        kw = {"width": length}
        if draw(st.booleans()):
            kw["cutoff"] = draw(st.one_of(magnitudes, scalars))
        if draw(st.booleans()):
            kw["normalize"] = draw(st.sampled_from(["full", "truncated", "FULL", None, 1]))
        if draw(st.booleans()):
            kw["line_quadrature"] = draw(st.sampled_from(["exact", "auto", 0, 1, 8, 16, 17, -1, 2.0, None, "x"]))
    else:
        kw = {("cutoff" if kind == "Lucy" else "radius"): length}
    if draw(st.booleans()):
        kw["averaged_axes"] = draw(st.sampled_from(["marginal", "lower-dimensional", "Marginal", "1d", None, 1, True]))
    return kind, kw


def make_kernel(case):
    kind, kw = case
    kernel, _ = call(getattr(cg, kind), **kw)
    return kernel


@st.composite
def grid_case(draw, dim):
    which = draw(st.sampled_from(["good", "shape", "average", "huge"]))
    shape = tuple(draw(st.integers(1, 4)) for _ in range(dim))
    average = ()
    if which == "shape":
        # (no node counts between 1e6 and 1e10: such grids fit in memory and are legitimately slow)
        items = st.one_of(st.integers(-2, 5), st.sampled_from(EXTREME_FLOATS + WEIRD + [10 ** 12, 10 ** 30]))
        shape = draw(st.one_of(items, st.lists(items, max_size=4)))
    elif which == "average":
        average = draw(st.one_of(scalars, st.lists(st.sampled_from(["x", "y", "z", 0, 1, 2, 3, -1, "q"]),
                                                   max_size=3)))
    elif which == "huge":
        shape = (draw(st.sampled_from([10 ** 12, 10 ** 18, 2 ** 62, 10 ** 30])),) + (1,) * (dim - 1)
    return shape, average


# ---------------------------------------------------------------- the pipeline with identities
FIELD_LISTS = [("density",), ("density", "velocity"), ("density", "momentum", "kinetic_stress"),
               ("stress",), ("contact_stress", "boundary_stress", "interaction_force_density"),
               ("extended_stress",), ("volume_fraction",), ("pressure", "temperature"), ("body_force_density",),
               ("density", "bogus"), (), "density", ("density", "density")]


def check_result(out, snap, target):
    """Finite where promised, and the total-mass identity on a grid that averages every axis."""
    for name in out.fields:
        value = np.asarray(out[name])
        if name in ("velocity", "temperature"):
            # documented (docs/getting-started.md, Fields): NaN where the density is 0; finite elsewhere
            rho = np.asarray(out["density"]) if "density" in out.fields else None
            if rho is not None:
                where = rho > 0
                inner = value[where]
                assert np.all(np.isfinite(inner)), f"{name} not finite where density > 0"
            continue
        assert np.all(np.isfinite(value)), f"{name} not finite: {value}"


def mass_identity(snap, kernel):
    """A grid averaging every axis gives density = total flowing mass / volume (exact marginals)."""
    box = snap.box
    grid = cg.Grid(box, (1,) * snap.dim, average=tuple(range(snap.dim)))
    out = cg.coarse_grain(snap, grid, kernel, fields=("density",))
    flow = ~snap.fixed
    expected = snap.masses[flow].sum() / np.prod(box.lengths)
    got = float(np.asarray(out["density"]).ravel()[0])
    assert np.isfinite(got), f"density {got} for total mass {snap.masses[flow].sum()} in volume {box.lengths}"
    assert math.isclose(got, expected, rel_tol=1e-9, abs_tol=1e-300), (got, expected)


def run_pipeline(snap, kernel, grid_args, fields, convention, species, use_points, rng_seed):
    if snap is None or kernel is None:
        return
    dim = snap.dim
    rng = np.random.default_rng(rng_seed)
    if use_points:
        target = rng.uniform(0, 1, (3, dim)) * snap.box.lengths + snap.box.lower
    else:
        target, exc = call(cg.Grid, snap.box, grid_args[0], average=grid_args[1])
        if target is None:
            return
    out, exc = call(cg.coarse_grain, snap, target, kernel, fields=fields, convention=convention, species=species)
    if out is not None:
        check_result(out, snap, target)
    if exc is None and out is not None and species is None and len(snap.fixed) and fields == ("density",):
        mass_identity(snap, kernel)


def residual_case(snap, kernel, forces):
    if snap is None or kernel is None:
        return
    rng = np.random.default_rng(0)
    pts = rng.uniform(0, 1, (2, snap.dim)) * snap.box.lengths + snap.box.lower
    res, exc = call(cg.momentum_balance_residual, snap, pts, kernel, forces=forces)
    if res is not None:
        for term in res.terms.values() if hasattr(res, "terms") else ():
            assert np.all(np.isfinite(term))


def writers_case(out, path_kind, frame):
    """Writers with hostile paths and frames: the file is written, or a named / OS error; no temporary left."""
    with tempfile.TemporaryDirectory() as d:
        path = {"file": os.path.join(d, "out.h5"), "dir": d, "missing_dir": os.path.join(d, "no", "out.h5"),
                "empty": "", "none": None, "int": 3}[path_kind]
        for write in (out.to_npz, out.to_hdf5, lambda p: out.to_vtk(p, frame=frame)):
            try:
                write(path)
            except NAMED as exc:
                assert_named(exc)
            except OSError as exc:
                assert path_kind in ("dir", "missing_dir") and str(exc).startswith(f"[Errno {exc.errno}] path:"), exc
            leftovers = [n for n in os.listdir(d) if ".cgbound-tmp-" in n]
            assert leftovers == [], leftovers
