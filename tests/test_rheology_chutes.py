"""mu(I) from chutes at several inclinations: the scene, the mu(I) fit, and the physics of the shipped profiles.

The shipped profiles (cgbound/data/rheology_chutes.h5, scripts/make_rheology_chutes.py) must show what
steady uniform chute flow requires: -sigma_xz/sigma_zz = tan(theta) in the bulk within the block error
bars, the analytic shear rate equal to the slope of the velocity profile, friction and inertial number
rising with the inclination, and a Jop-Forterre-Pouliquen fit with physical parameters.
"""
import numpy as np
import pytest

import cgbound as cg
from cgbound.paper import chute_rheology, scenes
from cgbound.paper.datasets import rheology_chutes
from cgbound.paper.scenes import Frames, Run

LAMMPS = scenes.find_lammps()
needs_lammps = pytest.mark.skipif(LAMMPS is None, reason="LAMMPS (lmp) not installed")


# -- the scene ----------------------------------------------------------------------------------------

def test_inclined_chute_has_exactly_the_chute_effects_and_tilted_gravity():
    scene = scenes.inclined_chute(23.5)
    assert scene.effects == ("3D", "normal contact force", "normal contact damping", "tangential contact force",
                             "tangential contact damping", "sliding friction", "rotation", "gravity",
                             "fixed particles", "periodic x", "periodic y")
    theta = np.radians(23.5)
    np.testing.assert_allclose(scene.gravity, [np.sin(theta), 0.0, -np.cos(theta)], rtol=0, atol=1e-15)
    flowing = ~scene.fixed
    assert flowing.sum() == 1300
    d = 2 * scene.radii[flowing]
    assert 0.9 <= d.min() and d.max() <= 1.1 and abs(d.mean() - 1) < 0.01
    np.testing.assert_allclose(scene.masses, (2 * scene.radii) ** 3)          # the density of m = 1, d = 1
    # no initial overlaps among the flowing particles (minimum image in x, y)
    x = scene.positions[flowing]
    delta = x[:, None, :] - x[None, :, :]
    delta[..., :2] -= scene.box.lengths[:2] * np.round(delta[..., :2] / scene.box.lengths[:2])
    gap = np.linalg.norm(delta, axis=2) - (scene.radii[flowing][:, None] + scene.radii[flowing][None, :])
    np.fill_diagonal(gap, np.inf)
    assert gap.min() >= 0


def test_inclined_chute_input_script_has_the_softer_contacts_and_the_tilt():
    scene = scenes.inclined_chute(25.0)
    text = scenes.input_script(scene, [Run(1.0), Frames(2, 0.5)])
    g = float(50.0 / np.sqrt(10.0))
    assert f"pair_style      gran/hooke/history 20000.0 {repr(2.0 / 7.0 * 2e4)} {repr(g)} {repr(g)} 0.5 1" in text
    theta = np.radians(25.0)
    assert (f"fix             gravity flow gravity 1.0 vector {repr(float(np.sin(theta)))} 0.0 {repr(float(-np.cos(theta)))}"
            in text)
    for word in ("wall/gran", "viscous", "enforce2d"):
        assert word not in text
    assert "timestep        0.0005" in text


def test_softer_contacts_keep_the_papers_restitution_and_resolve_the_collision():
    model = scenes.RHEOLOGY_CONTACT_MODEL
    # kn ten times smaller and the damping rate sqrt(10) times smaller: gamma t_c is unchanged, so is e
    assert model.restitution() == pytest.approx(scenes.PAPER_CONTACT_MODEL.restitution(), rel=1e-12)
    smallest_pair = 0.5 * 0.9 ** 3
    assert scenes.RHEOLOGY_TIMESTEP <= model.collision_time(smallest_pair) / 25


def test_same_seed_same_base_and_start_at_every_angle():
    a, b = scenes.inclined_chute(22.0), scenes.inclined_chute(26.5)
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.radii, b.radii)
    assert a.name != b.name


@pytest.mark.parametrize("angle", [0.0, 90.0, -5.0, float("nan"), float("inf")])
def test_bad_angle_is_refused(angle):
    with pytest.raises(ValueError, match="angle"):
        scenes.inclined_chute(angle)


def test_bad_flowing_diameters_are_refused_before_any_work():
    with pytest.raises(ValueError, match="flowing_diameters"):
        scenes.chute(flowing_diameters=(1.1, 0.9))
    with pytest.raises(ValueError, match="flowing_diameters"):
        scenes.chute(flowing_diameters=(0.0, 1.0))


@needs_lammps
def test_a_short_inclined_chute_runs_and_its_profiles_round_trip(tmp_path):
    scene = scenes.inclined_chute(24.0, n_flowing=120, length=4.0, width=4.0, seed=3)
    run = scenes.run_scene(scene, [Run(1.0, thermo_every=0.5), Frames(4, 0.25)], workdir=tmp_path / "lmp")
    assert len(run.snapshots) == 4
    snap = run.snapshots[-1]
    pts = snap.box.lower + np.random.default_rng(0).random((30, 3)) * snap.box.lengths
    assert cg.momentum_balance_residual(snap, pts, cg.Lucy(1.0)).relative.max() < 1e-10
    profiles = chute_rheology.ChuteProfiles(24.0, n_blocks=2).run(run.snapshots)
    profiles.provenance = {"spinup": 1.0, "window": 0.75}
    profiles.kinetic_energy = (run.thermo["time"], run.thermo["kinetic_energy"])
    path = chute_rheology.write_profiles(tmp_path / "p.h5", [profiles])
    back, = chute_rheology.read_profiles(path)
    assert back.angle == 24.0 and back.n_frames == 4
    for name in chute_rheology.PROFILE_FIELDS:
        np.testing.assert_array_equal(back.fields[name], profiles.fields[name])
        np.testing.assert_array_equal(back.errors[name], profiles.errors[name])
    # the density profile (averaged over x and y) integrates to the flowing mass per unit area, but for the
    # Gaussian tails (w = 0.5) of the lowest particles (z ~ 1) below the profile's start at z = -1 (~4 w): ~1e-5
    mass = back.fields["density"].sum() * back.spacing * 16.0
    assert mass == pytest.approx(snap.masses[snap.flowing].sum(), rel=1e-4)
    assert mass < snap.masses[snap.flowing].sum()


# -- the mu(I) fit ------------------------------------------------------------------------------------

def test_fit_recovers_the_law_from_exact_points():
    i = np.array([0.02, 0.05, 0.1, 0.2, 0.4, 0.8, 1.6])
    fit = cg.fit_mu_of_i(i, cg.mu_of_i(i, 0.38, 0.64, 0.279))
    assert (fit.mu_s, fit.mu_2, fit.i_0) == pytest.approx((0.38, 0.64, 0.279), rel=1e-7)
    assert fit.chi2 < 1e-20 and fit.dof == 4


def test_fit_and_its_covariance_agree_with_scipy_curve_fit():
    optimize = pytest.importorskip("scipy.optimize")
    rng = np.random.default_rng(4)
    i = np.linspace(0.05, 0.6, 15)
    sigma = rng.uniform(0.005, 0.02, i.size)
    mu = cg.mu_of_i(i, 0.4, 0.7, 0.3) + rng.normal(0, sigma)
    for kwargs in ({"sigma": sigma}, {}):
        fit = cg.fit_mu_of_i(i, mu, **kwargs)
        # curve_fit's default tolerances (1e-8) stop it some 4e-5 short of the optimum: converge it fully
        p, cov = optimize.curve_fit(cg.mu_of_i, i, mu, p0=[0.4, 0.7, 0.3], absolute_sigma=bool(kwargs),
                                    xtol=1e-14, ftol=1e-14, gtol=1e-14, **kwargs)
        np.testing.assert_allclose([fit.mu_s, fit.mu_2, fit.i_0], p, rtol=1e-6)
        np.testing.assert_allclose(fit.covariance, cov, rtol=1e-4)


@pytest.mark.parametrize("i, mu, sigma, match", [
    ([0.1, 0.2, 0.3], [0.4, 0.5, 0.6], None, "at least 4"),
    ([0.1, 0.2, 0.3, 0.4], [0.4, 0.5, 0.6], None, "friction"),
    ([0.1, 0.2, -0.3, 0.4], [0.4, 0.5, 0.6, 0.7], None, "inertial_number"),
    ([0.1, 0.2, 0.3, 0.4], [0.4, 0.5, np.nan, 0.7], None, "friction"),
    ([0.1, 0.1, 0.2, 0.2], [0.4, 0.5, 0.6, 0.7], None, "distinct"),
    ([0.1, 0.2, 0.3, 0.4], [0.4, 0.5, 0.6, 0.7], [0.1, 0.1, 0.0, 0.1], "sigma"),
])
def test_fit_refuses_bad_input(i, mu, sigma, match):
    with pytest.raises(ValueError, match=match):
        cg.fit_mu_of_i(i, mu, sigma=sigma)


# -- the shipped profiles -----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def chutes():
    return rheology_chutes()


def test_shipped_profiles_cover_four_steady_inclinations(chutes):
    assert [c.angle for c in chutes] == list(chute_rheology.ANGLES) and len(chutes) >= 4
    for c in chutes:
        assert c.n_frames == int(round(c.provenance["window"] / c.provenance["frame_interval"])) + 1
        assert abs(c.kinetic_energy_drift()) < 0.05, c.angle
        assert "LAMMPS" in c.provenance["lammps_version"]


def test_stress_ratio_is_tan_theta_in_the_bulk_within_the_error_bars(chutes):
    for c in chutes:
        ratio, error = c.stress_ratio()
        mean, bound = c.bulk_mean(None, ratio, error)
        assert abs(mean - c.tan_angle) < 2 * bound, (c.angle, mean, bound)
        assert bound < 0.05 * c.tan_angle          # the check has teeth: the bars are a few per cent at most


def test_shear_rate_is_the_slope_of_the_velocity_profile(chutes):
    for c in chutes:
        b = c.bulk
        slope = np.gradient(c.fields["velocity"][:, 0], c.z)
        rate = c.fields["shear_rate"]
        assert np.max(np.abs(rate[b] - np.abs(slope[b]))) < 0.02 * rate[b].max(), c.angle
        # and the velocity gradient's xz component is that slope with its sign
        L = c.fields["velocity_gradient"]
        assert np.max(np.abs(L[b, 0, 2] - slope[b])) < 0.02 * rate[b].max()


def test_mu_of_i_rises_with_the_inclination_and_the_fit_is_physical(chutes):
    i = np.array([c.bulk_mean("inertial_number")[0] for c in chutes])
    mu, emu = np.array([c.bulk_mean("friction") for c in chutes]).T
    assert np.all(np.diff(i) > 0) and np.all(np.diff(mu) > 0)
    fit = cg.fit_mu_of_i(i, mu, sigma=emu)
    assert 0.2 < fit.mu_s < mu.min() < mu.max() < fit.mu_2 < 1.2
    assert 0.0 < fit.i_0 < 2.0
    assert np.all(np.abs(fit(i) - mu) < 3 * emu)


def test_chute_profiles_refuse_bad_input_before_any_work():
    with pytest.raises(ValueError, match="angle"):
        chute_rheology.ChuteProfiles(90.0)
    with pytest.raises(ValueError, match="n_blocks"):
        chute_rheology.ChuteProfiles(24.0, n_blocks=1)
    with pytest.raises(ValueError, match="frames"):
        chute_rheology.ChuteProfiles(24.0, n_blocks=4).run([])
    with pytest.raises(TypeError, match="frames"):
        chute_rheology.ChuteProfiles(24.0).run(iter([]))
