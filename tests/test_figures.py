"""Figures a scientist can put in a paper: labels with symbol, sign and unit (or "(simulation units)"),
labelled colorbars, legends naming every line, equal-aspect maps, vector formats by extension, reprs."""
import os
import subprocess
import sys

import numpy as np
import pytest

import cgbound as cg
from cgbound.paper.datasets import boundary_2d, chute_dense_profiles, chute_steady
from helpers import random_snapshot

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

MAGIC = {"png": b"\x89PNG\r\n\x1a\n", "pdf": b"%PDF-", "svg": b"<?xml"}


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


@pytest.fixture(scope="module")
def chute_profile():
    frames = chute_steady()
    grid = cg.Grid(frames[0].box, (1, 1, 60), average=("x", "y"))
    return cg.CoarseGrain(frames[:3], grid, cg.Gaussian(0.25), fields=("density", "velocity", "stress"),
                          convention="compression").run().results


def legend_names_every_line(ax):
    legend = ax.get_legend()
    assert legend is not None, "no legend"
    names = [t.get_text() for t in legend.get_texts()]
    lines = [line.get_label() for line in ax.get_lines()]
    assert lines and all(not name.startswith("_") for name in lines), f"unnamed lines: {lines}"
    assert sorted(names) == sorted(lines), f"legend {names} != lines {lines}"


def test_profiles_in_a_grid_of_subplots_carry_symbol_sign_and_unit(chute_profile):
    fig, axes = plt.subplots(1, 3)
    for ax, name in zip(axes, ("density", "velocity", "stress")):
        assert chute_profile.plot(name, ax=ax) is ax
    assert axes[0].get_xlabel() == r"$\rho$ [m / d³]"
    assert axes[0].get_ylabel() == "z [d]"
    assert "[√(g d)]" in axes[1].get_xlabel()
    assert axes[2].get_xlabel() == r"$-\sigma_{ij}$ (compression) [m g / d²]"
    legend_names_every_line(axes[1])
    legend_names_every_line(axes[2])
    assert len(axes[2].get_lines()) == 6                      # xx xy xz yy yz zz
    ax = chute_profile.plot("stress", component="zz")
    assert ax.get_xlabel() == r"$-\sigma_{zz}$ (compression) [m g / d²]"
    np.testing.assert_array_equal(ax.get_lines()[0].get_xdata(), chute_profile.stress[0, 0, :, 2, 2])


def test_without_units_labels_say_simulation_units():
    snap = random_snapshot(3, dim=2)
    out = cg.coarse_grain(snap, cg.Grid(snap.box, (1, 20), average="x"), cg.Gaussian(0.4),
                          fields=("stress", "pressure"))
    ax = out.plot("stress", component="zz")
    assert ax.get_xlabel() == r"$\sigma_{zz}$ (tension positive) (simulation units)"
    assert ax.get_ylabel() == "z (simulation units)"
    assert out.plot("pressure").get_xlabel() == "$p$ (compression positive) (simulation units)"


def test_maps_have_equal_aspect_labelled_axes_and_a_labelled_colorbar():
    snap = boundary_2d()
    out = cg.coarse_grain(snap, cg.Grid(snap.box, (30, 20)), cg.Gaussian(0.25),
                          fields=("interaction_force_density", "stress"))
    fig, axes = plt.subplots(1, 2)
    for ax, name in zip(axes, out.fields):
        assert out.plot(name, ax=ax) is ax
        assert ax.get_aspect() == 1.0
        assert ax.get_xlabel() == "x [d]" and ax.get_ylabel() == "z [d]"
    colorbars = [a for a in fig.axes if a not in axes]
    assert len(colorbars) == 2
    assert colorbars[0].get_ylabel() == "$|t|$ [m g / d²]"             # 2-D: a force per area
    assert colorbars[1].get_ylabel() == r"$\|\sigma\|$ (largest singular value) [m g / d]"
    snap.units = None
    bare = cg.coarse_grain(snap, cg.Grid(snap.box, (30, 20)), cg.Gaussian(0.25), fields=("density",))
    ax = bare.plot("density")
    assert ax.figure.axes[-1].get_ylabel() == r"$\rho$ (simulation units)"


def test_plot_refuses_what_it_cannot_draw():
    snap = random_snapshot(2, dim=3)
    out = cg.coarse_grain(snap, cg.Grid(snap.box, (3, 3, 3)), cg.Gaussian(0.5), fields=("density",))
    with pytest.raises(ValueError, match="field: expected one of the computed fields density"):
        out.plot("stress")
    with pytest.raises(ValueError, match="one resolved axis .* or two"):
        out.plot("density")
    assert out._repr_png_() is None and "<table>" in out._repr_html_()


def test_depth_profiles_figure_names_every_line_with_units():
    profiles = chute_dense_profiles()
    ax = profiles.plot()
    legend_names_every_line(ax)
    names = [line.get_label() for line in ax.get_lines()]
    assert any(n.startswith("bed") for n in names) and any(n.startswith("surface") for n in names)
    assert r"$-\sigma_{zz}$ (no correction)" in names              # compression positive: the sign says so
    assert ax.get_xlabel().endswith("[m g / d²]") and ax.get_ylabel() == "z [d]"


def test_result_shows_a_small_plot_in_jupyter(chute_profile):
    png = chute_profile._repr_png_()
    assert png.startswith(MAGIC["png"])
    html = chute_profile._repr_html_()
    assert "<img" in html and "data:image/png;base64," in html and "<td>m d^-3</td>" in html
    assert "mean over 3 frames" in html


def run_cli(*args, cwd):
    # the child imports the cgbound this test imported (in CI the checkout's uncompiled source would shadow
    # the installed package if the working directory came first)
    here = os.path.dirname(os.path.dirname(os.path.abspath(cg.__file__)))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([here] + sys.path))
    return subprocess.run([sys.executable, "-m", "cgbound", *args], cwd=cwd, env=env, capture_output=True, text=True)


@pytest.mark.parametrize("ext", ["pdf", "svg", "png"])
def test_cli_figures_are_written_in_the_format_of_their_extension(tmp_path, ext):
    from cgbound.paper.datasets import path
    proc = run_cli("run", path("chute_steady.h5"), "--stop", "2", "--grid", "1,1,40", "--average", "x,y",
                   "--fields", "density,stress", "--units", "mercury", "-o", "f.h5", "--figure", f"f.{ext}", "-q",
                   cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    with open(tmp_path / f"f.{ext}", "rb") as f:
        head = f.read(8)
    assert head.startswith(MAGIC[ext]), head
    if ext == "svg":
        text = (tmp_path / "f.svg").read_text()
        assert "<svg" in text and "image/png" not in text[:2000]


def test_cli_units_flag_is_checked_before_work(tmp_path):
    from cgbound.paper.datasets import path
    proc = run_cli("run", path("chute_steady.h5"), "--units", "furlongs", "-o", "f.h5", cwd=tmp_path)
    assert proc.returncode != 0 and "--units" in proc.stderr and not (tmp_path / "f.h5").exists()
    proc = run_cli("run", path("chute_steady.h5"), "--units", "metal", "--fields", "stress", "-o", "f.h5",
                   cwd=tmp_path)
    assert proc.returncode != 0 and "--fields" in proc.stderr and "commensurate" in proc.stderr


def test_demo_figure_is_a_real_pdf(tmp_path):
    proc = run_cli("demo", "-q", "--output", "d.h5", "--figure", "demo.pdf", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "demo.pdf").read_bytes().startswith(MAGIC["pdf"])


def test_save_figure_writes_the_format_of_the_extension(tmp_path, chute_profile):
    from cgbound.plot import save_figure
    ax = chute_profile.plot("density")
    for ext in MAGIC:
        path = save_figure(ax.figure, tmp_path / f"f.{ext.upper()}")
        assert open(path, "rb").read(8).startswith(MAGIC[ext]), ext
    with pytest.raises(ValueError, match=r"path: expected a file name ending in \.png, \.pdf, \.svg"):
        save_figure(ax.figure, tmp_path / "f.jpg")
    assert not (tmp_path / "f.jpg").exists()
