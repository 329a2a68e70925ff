import os
import sys

sys.path.insert(0, os.path.dirname(__file__))


def pytest_terminal_summary(terminalreporter):
    from stability_log import RESULTS
    if not RESULTS:
        return
    terminalreporter.section("numerical stability: accuracy reached on each hard case")
    for case, error in RESULTS.items():
        terminalreporter.write_line(f"{case:<62} {error:.1e}")
