"""cgbound.plot draws what the fields say (Agg backend, no display)."""
import numpy as np
import pytest

import cgbound as cg
from cgbound.paper.datasets import boundary_2d

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")
from cgbound import plot  # noqa: E402


def test_map_shows_the_norms_of_fig1():
    snap = boundary_2d()
    out = cg.coarse_grain(snap, cg.Grid(snap.box, (44, 28)), cg.Gaussian(0.125),
                          fields=("interaction_force_density", "stress"))
    ax = plot.field_map(out, "interaction_force_density")
    image = ax.get_images()[0].get_array()
    np.testing.assert_array_equal(image, np.linalg.norm(out.interaction_force_density, axis=-1).T)
    ax = plot.field_map(out, "stress")
    # |sigma| = max over unit x of |sigma x|, by brute force over directions (the frictional stress is asymmetric)
    angle = np.linspace(0, np.pi, 2001)
    x = np.stack([np.cos(angle), np.sin(angle)])
    expected = np.linalg.norm(np.einsum("...ab,bk->...ak", out.stress, x), axis=-2).max(axis=-1).T
    np.testing.assert_allclose(ax.get_images()[0].get_array(), expected, rtol=1e-6)  # the direction grid resolves the maximum to ~1e-7
    plot.particles(ax, snap)
    assert len(ax.patches) == snap.n_particles


def test_profile_plots_the_component_against_depth():
    snap = boundary_2d()
    out = cg.coarse_grain(snap, cg.Grid(snap.box, (1, 50), average="x"), cg.Gaussian(0.25), fields=("stress",))
    ax = plot.profile(out, "stress", component="zz")
    x, y = ax.get_lines()[0].get_data()
    np.testing.assert_array_equal(x, out.stress[0, :, 1, 1])
    np.testing.assert_array_equal(y, out.grid.axis_coordinates[1])
    with pytest.raises(ValueError, match="component"):
        plot.profile(out, "stress", component="z")
    with pytest.raises(ValueError, match="one resolved axis"):
        plot.profile(cg.coarse_grain(snap, cg.Grid(snap.box, (4, 4)), cg.Lucy(1), fields=("density",)), "density")
