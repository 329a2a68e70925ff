import os
import signal
import sys

import pytest

sys.path.insert(0, os.path.dirname(__file__))

# Tests whose time goes to Python-side work: nested scipy/mpmath quadrature oracles, external engines
# (LAMMPS), plotting, Dask clusters, or C programs built without the sanitizer. They carry the marker
# `python_bound`, and tools/sanitize.sh deselects them: only our extension is instrumented, so they
# would add minutes there and no coverage. Every C entry point they reach is also reached, under the
# sanitizer, by its twin tests (tests/test_core_sweep.py, test_ring_core.py, test_axial_core.py, ...).
PYTHON_BOUND = {
    "test_c_program.py": None,                    # builds and runs its own binaries, without ASan
    "test_dask.py": None,                         # clusters; the kernels are the serial ones
    "test_figures.py": None,                      # matplotlib
    "test_cylindrical_virial.py": None,           # identities over the ring paths
    "test_rheology_chutes.py": {"test_inclined_chute_has_exactly_the_chute_effects_and_tilted_gravity",
                                "test_inclined_chute_input_script_has_the_softer_contacts_and_the_tilt",
                                "test_same_seed_same_base_and_start_at_every_angle",
                                "test_a_short_inclined_chute_runs_and_its_profiles_round_trip"},
    "test_cylindrical.py": {"test_ring_average_equals_brute_force_oracle"},
    "test_cylindrical_ring.py": {"test_ring_moments_against_32_digit_quadrature",
                                 "test_z_averaged_fields_equal_nested_adaptive_quadrature",
                                 "test_contact_stress_line_integrals_equal_nested_quadrature"},
    "test_cylindrical_axial.py": {"test_contact_and_boundary_stress_equal_nested_quadrature",
                                  "test_degenerate_segments_equal_nested_quadrature"},
    "test_cylindrical_zstress.py": {"test_z_averaged_stresses_equal_adaptive_quadrature"},
    "test_cylindrical_gradients.py": {"test_exact_ring_gradients_against_adaptive_quadrature",
                                      "test_theta_resolved_z_averaged_point_sums_are_exact"},
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
    config.addinivalue_line("markers", "python_bound: the time is Python-side work (oracles, engines, "
                                       "plots); tools/sanitize.sh deselects these")


def pytest_collection_modifyitems(config, items):
    for item in items:
        names = PYTHON_BOUND.get(item.path.name, ())
        if names is None or item.originalname in names:
            item.add_marker(pytest.mark.python_bound)


def pytest_terminal_summary(terminalreporter):
    from stability_log import RESULTS
    if not RESULTS:
        return
    terminalreporter.section("numerical stability: accuracy reached on each hard case")
    for case, error in RESULTS.items():
        terminalreporter.write_line(f"{case:<62} {error:.1e}")
