"""Choosing the width (cg.width_scan): fields against w and the plateau where they stop depending on it.

The synthetic case is a chain of particles one spacing apart along z in a periodic box, profiled along z: below
the spacing the density resolves single particles, and with masses varying on a long wavelength the widest
kernels smooth the variation away; between the two lies the plateau (scale separation). The expected fields are
sums of untruncated 1D Gaussians over the periodic images, written here from the formula.
"""
import numpy as np
import pytest

import cgbound as cg

N, WAVELENGTH = 40, 20.0
WIDTHS = np.geomspace(0.1, 3.0, 16)


def chain(amplitude):
    box = cg.Box([0, 0, 0], [1, 1, N], periodic=(True, True, True))
    z = np.arange(N) + 0.5
    positions = np.stack([np.full(N, 0.5), np.full(N, 0.5), z], axis=1)
    return cg.Snapshot(positions, masses=1 + amplitude * np.sin(2 * np.pi * z / WAVELENGTH), box=box)


def profile_by_formula(snap, nodes, w):
    z = np.asarray(snap.positions)[:, 2]
    m = np.asarray(snap.masses)
    out = np.zeros(nodes.shape)
    for image in range(-3, 4):
        d = nodes[:, None] - (z[None, :] + image * N)
        out += (m[None, :] * np.exp(-0.5 * (d / w) ** 2) / (np.sqrt(2 * np.pi) * w)).sum(axis=1)
    return out


def expected_sensitivity(snap, nodes):
    f = [profile_by_formula(snap, nodes, w) for w in WIDTHS]
    return np.array([np.sqrt(np.mean((f[k + 1] - f[k]) ** 2)) / np.sqrt(np.mean(f[k] ** 2))
                     / np.log(WIDTHS[k + 1] / WIDTHS[k]) for k in range(len(WIDTHS) - 1)])


def plateau_of(sensitivity, tolerance):
    runs, start = [], None
    for k, ok in enumerate(list(sensitivity <= tolerance) + [False]):
        if ok and start is None:
            start = k
        if not ok and start is not None:
            runs.append((k - start, -start, start, k))
            start = None
    if not runs:
        return None
    _, _, first, last = max(runs)
    return WIDTHS[first], WIDTHS[last]


@pytest.mark.parametrize("amplitude", [0.0, 0.5])
def test_sensitivity_and_plateau_follow_the_formula(amplitude):
    snap = chain(amplitude)
    grid = cg.Grid(snap.box, (1, 1, 80), average=("x", "y"))
    scan = cg.width_scan(snap, grid, WIDTHS, fields=("density",))
    nodes = (np.arange(80) + 0.5) * N / 80
    want = expected_sensitivity(snap, nodes)
    # the kernel's truncation at 5 widths leaves ~1e-6 relative in each field
    np.testing.assert_allclose(scan.sensitivity["density"], want, rtol=1e-3, atol=1e-4)
    assert scan.plateau["density"] == pytest.approx(plateau_of(want, 0.05))
    assert scan.fields["density"].shape == (len(WIDTHS), 1, 1, 80)
    for w, field in zip(WIDTHS, scan.fields["density"]):
        np.testing.assert_allclose(field.ravel(), profile_by_formula(snap, nodes, w), rtol=1e-5, atol=1e-5)
    first, last = scan.plateau["density"]
    assert 0.25 < first < 0.5                     # the particle scale: the spacing is 1
    if amplitude == 0.0:
        assert last == WIDTHS[-1]                 # nothing to smooth away
    else:
        assert 0.8 < last < 2.0                   # the flow's scale: w ~ 0.06 wavelength at 5 % per e-fold


def test_no_plateau_below_the_particle_scale():
    snap = chain(0.0)
    scan = cg.width_scan(snap, cg.Grid(snap.box, (1, 1, 80), average=("x", "y")), [0.05, 0.08, 0.12, 0.18],
                         fields=("density",))
    assert scan.plateau["density"] is None


def test_a_sequence_of_frames_is_time_averaged_and_other_kernels_scan_their_own_length():
    frames = [chain(0.0), chain(0.0)]
    grid = cg.Grid(frames[0].box, (1, 1, 20), average=("x", "y"))
    scan = cg.width_scan(frames, grid, [1.0, 2.0, 3.0, 4.0], fields=("density", "number_density"), kernel=cg.Lucy)
    one = cg.coarse_grain(frames[0], grid, cg.Lucy(2.0), fields=("density",)).density
    np.testing.assert_allclose(scan.fields["density"][1], one, rtol=1e-14)
    assert set(scan.plateau) == {"density", "number_density"}


def test_plot_returns_the_axes():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    snap = chain(0.5)
    scan = cg.WidthScan(snap, cg.Grid(snap.box, (1, 1, 40), average=("x", "y")), WIDTHS[::3],
                        fields=("density",)).run()
    fig, ax = plt.subplots()
    assert scan.plot(ax) is ax
    assert scan.plot() is not None
    plt.close("all")


@pytest.mark.parametrize("widths, kernel, match", [
    ([0.5, 1.0], cg.Gaussian, "widths"),
    ([1.0, 0.5, 2.0], cg.Gaussian, "widths"),
    ([-1.0, 0.5, 2.0], cg.Gaussian, "widths"),
    ([0.5, 1.0, 2.0], "gaussian", "kernel"),
])
def test_bad_scan_arguments_are_refused(widths, kernel, match):
    snap = chain(0.0)
    with pytest.raises((TypeError, ValueError), match=match):
        cg.WidthScan(snap, cg.Grid(snap.box, (1, 1, 4), average=("x", "y")), widths, kernel=kernel)
    with pytest.raises(RuntimeError, match="run"):
        cg.WidthScan(snap, cg.Grid(snap.box, (1, 1, 4), average=("x", "y")), [0.5, 1.0, 2.0]).plot()
