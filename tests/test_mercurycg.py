"""MercuryCG .stat files: reading genuine files, writing, round trips, and cgbound against MercuryCG's numbers."""
import os

import numpy as np
import pytest

import cgbound as cg
from cgbound.mercurycg import read_stat, stat_kernel, to_fields, write_stat
from cgbound.readers.mercury import MercuryReader
from cgbound.result import Result

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "mercurycg")
CHUTE = os.path.join(DATA, "ChutePeriodicDemo_t15")
FIELDS = ["density", "momentum", "momentum_flux", "contact_stress", "boundary_stress", "interaction_force_density",
          "volume_fraction"]
PAIRS = [("density", "Density"), ("momentum", "Momentum"), ("momentum_flux", "MomentumFlux"),
         ("interaction_force_density", "InteractionForce"), ("volume_fraction", "VolumeFraction")]


def printed(x, digits=6):
    """x as it reads back after printing with %.<digits>g."""
    return np.vectorize(lambda v: float(f"{v:.{digits}g}"))(x)


def agree_to_printed_digits(ours, theirs):
    """|ours - theirs| within the rounding of 6 printed digits (plus round-off of sums that cancel to ~0)."""
    bound = 5.0e-6 * np.abs(theirs) + 1e-12 * max(float(np.abs(theirs).max()), 1e-300)
    return np.abs(ours - theirs) <= bound


def test_read_genuine_headers():
    o = read_stat(os.path.join(DATA, "ChutePeriodicDemo.O.stat"))
    assert o.coordinates == "O" and o.shape == () and o.function == "Lucy" and o.width == 1 and o.cutoff == 1
    assert o.time_min == 15 and o.time_max is None
    assert np.array_equal(o.times, [15, 17.5, 20, 20.0001])
    assert np.array_equal(o.upper, [30, 5, 11.0948])
    assert o.column_order == ("VolumeFraction", "Density", "Momentum", "MomentumFlux", "ContactStress",
                              "InteractionForce", "ParticleSize")
    assert o.columns["Density"][0] == 0.481908
    k = o.columns["MomentumFlux"][0]       # file order xx xy xz yy yz zz, symmetric
    assert (k[0, 0], k[0, 1], k[1, 0], k[2, 2]) == (0.0351246, -0.000146067, -0.000146067, 0.00330792)
    s = o.columns["ContactStress"][0]      # file order xx xy xz yx ... (row-major)
    assert (s[0, 0], s[0, 2], s[2, 0], s[2, 2]) == (0.97245, -0.356578, -0.358135, 0.877941)
    z = read_stat(CHUTE + ".Z_Gauss_w0.5.stat")
    assert z.coordinates == "Z" and z.shape == (140,) and z.cutoff == 1.5
    assert np.allclose(z.axis_coordinates["z"][:2], [-1.95, -1.85])
    kern = z.kernel()
    assert isinstance(kern, cg.Gaussian) and kern.truncated and kern.cutoff == 1.5 and kern.width == 0.5
    x = read_stat(CHUTE + ".XYZ_Lucy_w1_interior.stat")
    assert x.shape == (13, 3, 10) and x.columns["Density"].shape == (1, 13, 3, 10)
    assert np.allclose(x.axis_coordinates["x"], np.arange(3, 28, 2))
    # row 4 of the file (x=3, y=1.5, z=1.5)
    assert x.columns["Density"][0, 0, 0, 2] == float(open(CHUTE + ".XYZ_Lucy_w1_interior.stat").read()
                                                    .splitlines()[4].split()[5])
    assert isinstance(x.kernel(), cg.Lucy) and x.kernel().cutoff == 1


def test_to_fields_signs():
    o = read_stat(os.path.join(DATA, "ChutePeriodicDemo.O.stat"))
    comp, tens = to_fields(o, "compression"), to_fields(o, "tension")
    assert np.array_equal(comp["contact_and_boundary_stress"], o.columns["ContactStress"])
    assert np.array_equal(tens["contact_and_boundary_stress"], -o.columns["ContactStress"])
    rho, p, k = o.columns["Density"][0], o.columns["Momentum"][0], o.columns["MomentumFlux"][0]
    assert np.allclose(comp["kinetic_stress"][0], k - np.outer(p, p) / rho, rtol=1e-14, atol=0)
    assert np.allclose(tens["stress"], -(comp["kinetic_stress"] + o.columns["ContactStress"]), rtol=1e-14, atol=0)
    with pytest.raises(ValueError, match="convention"):
        to_fields(o, "pressure")


def small_snapshot():
    rng = np.random.default_rng(3)
    n = 40
    pos = rng.random((n, 3)) * [4, 3, 2]
    i = rng.integers(0, n, 30)
    j = (i + 1 + rng.integers(0, n - 1, 30)) % n
    keep = np.unique(np.sort(np.stack([i, j], 1), axis=1), axis=0)
    contacts = cg.Contacts(keep[:, 0], keep[:, 1], rng.normal(size=(len(keep), 3)),
                           0.5 * (pos[keep[:, 0]] + pos[keep[:, 1]]))
    fixed = np.zeros(n, bool)
    fixed[:5] = True
    return cg.Snapshot(pos, rng.normal(size=(n, 3)), rng.random(n) + 0.5, box=cg.Box([0, 0, 0], [4, 3, 2]),
                       contacts=contacts, fixed=fixed, radii=np.full(n, 0.1), time=2.5)


@pytest.mark.parametrize("average,shape", [((), (4, 3, 2)), (("x", "y"), (1, 1, 7)), (("x", "y", "z"), (1, 1, 1))])
@pytest.mark.parametrize("kernel", [cg.Lucy(0.8, averaged_axes="lower-dimensional"),
                                    cg.Gaussian(0.3, cutoff=0.9, normalize="truncated")])
def test_round_trip(tmp_path, average, shape, kernel):
    snap = small_snapshot()
    grid = cg.Grid(snap.box, shape, average=average)
    res = cg.coarse_grain(snap, grid, kernel, fields=FIELDS)
    path = tmp_path / "a.stat"
    write_stat(path, res, time_min=1)
    back = read_stat(path)
    coords = "".join(a.upper() for a in "xyz" if a not in average) or "O"
    assert back.coordinates == coords and back.time_min == 1 and np.array_equal(back.times, [2.5])
    assert back.function == ("Lucy" if isinstance(kernel, cg.Lucy) else "Gauss")
    assert back.kernel().cutoff == kernel.cutoff
    res_shape = tuple(s for d, s in enumerate(shape) if "xyz"[d] not in average)
    for ours, theirs in PAIRS:
        assert np.array_equal(back.columns[theirs][0], printed(res[ours].reshape(res_shape + res[ours].shape[3:])))
    # ContactStress is compression-positive: minus the tension-positive contact + boundary stress
    expected = printed(-(res["contact_stress"] + res["boundary_stress"]).reshape(res_shape + (3, 3)))
    assert np.array_equal(back.columns["ContactStress"][0], expected)
    # the same file from a compression-convention result; writing what was read gives the same text
    res_c = cg.coarse_grain(snap, grid, kernel, fields=FIELDS, convention="compression")
    write_stat(tmp_path / "b.stat", res_c, time_min=1)
    assert (tmp_path / "b.stat").read_text() == path.read_text()


def result_from_stat(stat, t):
    """A cgbound Result holding a .stat file's numbers at time index t (what a user would build to re-write it)."""
    f = to_fields(stat, "compression")
    avg = tuple(a for a in "xyz" if a.upper() not in stat.coordinates)
    grid = cg.Grid(cg.Box(stat.lower, stat.upper), tuple(int(k) for k in stat.n), average=avg)
    f["contact_stress"] = f.pop("contact_and_boundary_stress")
    f["boundary_stress"] = np.zeros_like(f["contact_stress"])
    fields = {k: f[k][t].reshape(grid.shape + f[k].shape[1 + len(stat.shape):])
              for k in ("density", "momentum", "momentum_flux", "interaction_force_density", "volume_fraction",
                        "contact_stress", "boundary_stress")}
    return Result(fields, grid, stat.kernel(), "compression", [stat.times[t]], grid.box)


@pytest.mark.parametrize("name", ["ChutePeriodicDemo.O.stat", "ChutePeriodicDemo_t15.Z_Gauss_w0.5.stat",
                                  "ChutePeriodicDemo_t15.XYZ_Lucy_w1_interior.stat"])
def test_rewrite_genuine_file(tmp_path, name):
    """Our writer reproduces MercuryCG's own file: header and every column it can write, to the printed digits."""
    stat = read_stat(os.path.join(DATA, name))
    path = tmp_path / "re.stat"
    write_stat(path, result_from_stat(stat, 0), time_min=stat.time_min)
    ours = path.read_text().splitlines()
    theirs = open(os.path.join(DATA, name)).read().splitlines()
    assert ours[0] == theirs[0]
    # MercuryCG's column line has ParticleSize last, which cgbound does not write
    assert theirs[1].startswith(ours[1].rstrip())
    back = read_stat(path)
    assert back.column_order == stat.column_order[:6]
    for col in back.column_order:
        assert np.array_equal(back.columns[col], stat.columns[col][:1]), col
    # the rows are MercuryCG's rows in MercuryCG's node order, text for text (ParticleSize's 6 columns aside)
    rows = len(ours) - 2
    assert [a.split() for a in ours[2:]] == [b.split()[:-6] for b in theirs[2:2 + rows]]


def test_write_errors(tmp_path):
    snap = small_snapshot()
    grid = cg.Grid(snap.box, (2, 2, 2))
    res = cg.coarse_grain(snap, grid, cg.Gaussian(0.3), fields=["density"])
    with pytest.raises(ValueError, match="normalize='truncated'"):
        write_stat(tmp_path / "a.stat", res)
    res = cg.coarse_grain(snap, grid, cg.Lucy(0.5), fields=["velocity"])
    with pytest.raises(ValueError, match="no MercuryCG column"):
        write_stat(tmp_path / "a.stat", res)
    res = cg.coarse_grain(snap, np.array([[1.0, 1.0, 1.0]]), cg.Lucy(0.5), fields=["density"])
    with pytest.raises(ValueError, match="cg.Grid"):
        write_stat(tmp_path / "a.stat", res)
    # a Z profile's header names MercuryCG's (lower-dimensional) Lucy: the marginal is refused
    for kernel in (cg.Lucy(0.5), cg.Heaviside(0.5)):
        res = cg.coarse_grain(snap, cg.Grid(snap.box, (1, 1, 4), average=("x", "y")), kernel, fields=["density"])
        with pytest.raises(ValueError, match="averaged_axes='lower-dimensional'"):
            write_stat(tmp_path / "a.stat", res)
    # the marginal and the lower-dimensional kernel are the same without averaged or without resolved axes
    for shape, average in (((2, 2, 2), ()), ((1, 1, 1), ("x", "y", "z"))):
        res = cg.coarse_grain(snap, cg.Grid(snap.box, shape, average=average), cg.Lucy(0.5), fields=["density"])
        write_stat(tmp_path / "a.stat", res)


def test_read_errors(tmp_path):
    bad = tmp_path / "bad.stat"
    bad.write_text("CG<Z> min 0 0 0 max 1 1 1 n 1 1 2 width 1 Lucy cutoff 1 bogus 3\ntime z 3:Density\n0 0.25 1\n0 0.75 2\n")
    with pytest.raises(ValueError, match="unknown header entry 'bogus'"):
        read_stat(bad)
    bad.write_text("CG<Z> min 0 0 0 max 1 1 1 n 1 1 2 width 1 Lucy cutoff 1\ntime z 3:Density\n0 0.25 1\n0 0.25 2\n")
    with pytest.raises(ValueError, match="every node exactly once"):
        read_stat(bad)
    bad.write_text("CG<Z> min 0 0 0 max 1 1 1 n 1 1 2 width 1 Lucy cutoff 1\ntime z 3:Density\n0 0.25 1\n0 0.6 2\n")
    with pytest.raises(ValueError, match="not a node"):
        read_stat(bad)
    bad.write_text("CG<Z> min 0 0 0 max 1 1 1 n 1 1 2 width 1 Lucy cutoff 1\ntime z 3-4:Momentum\n0 0.25 1 1\n0 0.75 2 2\n")
    with pytest.raises(ValueError, match="Momentum has 2 columns"):
        read_stat(bad)
    bad.write_text("x y z\n")
    with pytest.raises(ValueError, match="CG<"):
        read_stat(bad)
    with pytest.raises(ValueError, match="Lucy, Gauss or Heaviside"):
        stat_kernel("Cubic", 1.0)


@pytest.fixture(scope="module")
def chute():
    """The genuine MercuryDPM chute frame at t = 15 (fixed base: particles 0..209)."""
    theta = np.radians(24)
    reader = MercuryReader(CHUTE + ".data", CHUTE + ".fstat", fixed=np.arange(210), density=6 / np.pi,
                           periodic=(True, True, False), body_force=(np.sin(theta), 0, -np.cos(theta)))
    snap = reader[0]
    assert snap.time == 15 and snap.n_particles == 1012 and snap.fixed.sum() == 210
    return snap


@pytest.mark.parametrize("name", ["XYZ_Lucy_w1_interior", "Z_Gauss_w0.5"])
def test_cgbound_agrees_with_mercurycg(chute, name):
    """Where both define a quantity the same way, cgbound reproduces MercuryCG's numbers to its 6 printed digits.

    Density, momentum, momentum flux, interaction force density and volume fraction on the interior XYZ grid
    (Lucy) and on the Z profile (Gauss: the marginal of the 3-D Gaussian is the 1-D Gaussian, so both define
    the profile the same way). ContactStress agrees only on the middle y row of the XYZ grid: MercuryCG
    integrates contacts across the periodic y face from the partner's real position.
    """
    stat = read_stat(f"{CHUTE}.{name}.stat")
    avg = tuple(a for a in "xyz" if a.upper() not in stat.coordinates)
    grid = cg.Grid(cg.Box(stat.lower, stat.upper, periodic=chute.box.periodic), tuple(int(k) for k in stat.n),
                   average=avg)
    res = cg.coarse_grain(chute, grid, stat.kernel(), fields=FIELDS, convention="compression")
    for ours, theirs in PAIRS:
        a = res[ours].reshape(stat.columns[theirs][0].shape)
        assert np.all(agree_to_printed_digits(a, stat.columns[theirs][0])), ours
    if name.startswith("XYZ"):
        cs = (res["contact_stress"] + res["boundary_stress"])[:, 1]
        theirs = stat.columns["ContactStress"][0][:, 1]
        assert np.max(np.abs(cs - theirs)) <= 5e-6 * np.max(np.abs(theirs))


def test_time_axis_result(tmp_path):
    """A result with a time axis (time_average="none") is written as one block per frame time."""
    snaps = [small_snapshot() for _ in range(3)]
    for k, s in enumerate(snaps):
        s.time = 1.0 + k
    grid = cg.Grid(snaps[0].box, (1, 1, 5), average=("x", "y"))
    run = cg.CoarseGrain(snaps, grid, cg.Lucy(0.7, averaged_axes="lower-dimensional"), fields=["density", "momentum"],
                         time_average="none").run()
    res = run.results
    write_stat(tmp_path / "t.stat", res)
    back = read_stat(tmp_path / "t.stat")
    assert np.array_equal(back.times, [1.0, 2.0, 3.0])
    assert np.array_equal(back.columns["Density"], printed(res["density"].reshape(3, 5)))
    assert np.array_equal(back.columns["Momentum"], printed(res["momentum"].reshape(3, 5, 3)))
