import os
import signal
import sys

import pytest

sys.path.insert(0, os.path.dirname(__file__))

# Tests the sanitizer run leaves out (marker `sanitizer_redundant`; tools/sanitize.sh in CI deselects them):
# their time buys no coverage there. Either it goes to Python-side work (nested scipy/mpmath quadrature
# oracles, external engines such as LAMMPS, plotting, Dask clusters, C programs built without the sanitizer;
# only our extension is instrumented), or to C paths that other tests reach under the sanitizer with smaller
# inputs (a genuine silo through the ring paths, multi-frame time means). Every C entry point they reach is
# also reached, under the sanitizer, by its twin tests (tests/test_core_sweep.py, test_ring_core.py,
# test_ring_columns.py, test_axial_core.py, ...). An entry names a file (None: all of it), a test function
# (all its parameters), or one parametrization as pytest names it ("test_x[a-b]").
SANITIZER_REDUNDANT = {
    "test_c_program.py": None,                    # builds and runs its own binaries, without ASan
    "test_dask.py": None,                         # clusters; the kernels are the serial ones
    "test_figures.py": None,                      # matplotlib
    "test_cylindrical_virial.py": None,           # identities over the ring paths
    "test_rheology_chutes.py": {"test_inclined_chute_has_exactly_the_chute_effects_and_tilted_gravity",
                                "test_inclined_chute_input_script_has_the_softer_contacts_and_the_tilt",
                                "test_same_seed_same_base_and_start_at_every_angle",
                                "test_a_short_inclined_chute_runs_and_its_profiles_round_trip"},
    "test_cylindrical_ring.py": {"test_ring_moments_against_32_digit_quadrature",
                                 "test_z_averaged_fields_equal_nested_adaptive_quadrature",
                                 "test_contact_stress_line_integrals_equal_nested_quadrature"},
    "test_cylindrical_axial.py": {"test_contact_and_boundary_stress_equal_nested_quadrature",
                                  "test_degenerate_segments_equal_nested_quadrature"},
    "test_cylindrical_zstress.py": {"test_z_averaged_stresses_equal_adaptive_quadrature"},
    "test_cylindrical_gradients.py": {"test_exact_ring_gradients_against_adaptive_quadrature",
                                      "test_theta_resolved_z_averaged_point_sums_are_exact"},
    "test_segment_moments.py": {"test_first_moment_of_the_marginals_against_the_oracle"},   # scipy marginals
    "test_oracle.py": {"test_periodicity_choices_match_oracle"},        # the NumPy oracle over periodic images
    # C paths reached with smaller inputs elsewhere (test_ring_columns.py, test_cylindrical_balance.py's
    # random-data balances, the other parametrizations of test_time_mean_is_mean_of_frame_primaries)
    "test_cylindrical.py": {"test_ring_average_equals_brute_force_oracle", "test_mass_integral"},
    "test_cylindrical_balance.py": {"test_genuine_silo_balance"},
    "test_cylindrical_time.py": {"test_time_mean_is_mean_of_frame_primaries[kw1]"},
}


@pytest.fixture
def python_sigint_handler():
    """Python's own SIGINT handler for the test. A process started with SIGINT ignored (a background job of a
    non-interactive shell, as some CI runners start their steps) inherits SIG_IGN, and Python then leaves it
    alone: Ctrl-C tests would see no KeyboardInterrupt for a reason that is not ours."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def pytest_configure(config):
    config.addinivalue_line("markers", "sanitizer_redundant: the sanitizer run leaves these out (Python-side "
                                       "work, or C paths other tests reach; tests/conftest.py)")


def pytest_collection_modifyitems(config, items):
    for item in items:
        names = SANITIZER_REDUNDANT.get(item.path.name, ())
        if names is None or item.originalname in names or item.name in names:
            item.add_marker(pytest.mark.sanitizer_redundant)
def pytest_terminal_summary(terminalreporter):
    from stability_log import RESULTS
    if not RESULTS:
        return
    terminalreporter.section("numerical stability: accuracy reached on each hard case")
    for case, error in RESULTS.items():
        terminalreporter.write_line(f"{case:<62} {error:.1e}")
