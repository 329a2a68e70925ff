"""The C core's own test program (csrc/tests/test_core.c), built without Python.

It links cg_kernels.c, cg_scatter.c and cg_status.c (not the binding), so it
checks that the core is plain C11 (-Wall -Wextra -Werror, with and without
OpenMP) and runs it, also under valgrind when valgrind is installed.
"""
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
CSRC = ROOT / "csrc"
TESTS = CSRC / "tests"
SOURCES = [TESTS / "test_core.c"] + sorted(CSRC.glob("cg_*.c"))  # the core: every csrc/cg_*.c
FLAGS = ["-std=c11", "-Wall", "-Wextra", "-Werror", "-O2", "-g", f"-I{CSRC}"]
SUMMARY = re.compile(r"^(\d+) passed, 0 failed$")

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="POSIX C toolchain test")


def clean_env():
    """The environment without sanitizer preloads (tools/sanitize.sh sets them for python only)."""
    env = dict(os.environ)
    for name in ("LD_PRELOAD", "ASAN_OPTIONS", "UBSAN_OPTIONS", "LSAN_OPTIONS"):
        env.pop(name, None)
    env.setdefault("OMP_NUM_THREADS", "2")
    return env


def compiler():
    cc = os.environ.get("CC", "cc").split()
    if not shutil.which(cc[0]):
        pytest.skip(f"no C compiler ({cc[0]!r} not on PATH)")
    return cc


def build(tmp_path, openmp):
    exe = tmp_path / ("test_core_omp" if openmp else "test_core")
    cmd = compiler() + FLAGS + (["-fopenmp"] if openmp else []) + [str(s) for s in SOURCES] + ["-o", str(exe), "-lm"]
    res = subprocess.run(cmd, capture_output=True, text=True, env=clean_env())
    if openmp and res.returncode != 0 and "omp" in (res.stderr + res.stdout).lower():
        pytest.skip("the C compiler has no OpenMP support")
    assert res.returncode == 0, f"{' '.join(cmd)}\n{res.stdout}\n{res.stderr}"
    assert "warning" not in res.stderr.lower(), res.stderr
    return exe


def check_output(res):
    lines = res.stdout.strip().splitlines()
    assert res.returncode == 0, f"exit {res.returncode}\n{res.stdout}\n{res.stderr}"
    assert lines and SUMMARY.match(lines[-1]), f"unexpected summary line\n{res.stdout}\n{res.stderr}"
    assert int(SUMMARY.match(lines[-1]).group(1)) > 100


@pytest.fixture(scope="module")
def build_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("c_core")


@pytest.fixture(scope="module")
def serial(build_dir):
    return build(build_dir, openmp=False)


@pytest.fixture(scope="module")
def openmp(build_dir):
    return build(build_dir, openmp=True)


def test_c_core_program_serial(serial):
    res = subprocess.run([str(serial)], capture_output=True, text=True, env=clean_env(), timeout=300)
    check_output(res)


def test_c_core_program_openmp(openmp):
    res = subprocess.run([str(openmp)], capture_output=True, text=True, env=clean_env(), timeout=300)
    check_output(res)


@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind is not on PATH (apt-get install valgrind)")
def test_c_core_program_under_valgrind(request, serial):
    # the OpenMP build (when there is one) covers the threaded paths too;
    # `make -C csrc/tests valgrind` runs both builds
    try:
        exe = request.getfixturevalue("openmp")
    except pytest.skip.Exception:
        exe = serial
    cmd = ["valgrind", "--error-exitcode=1", "--leak-check=full", "--errors-for-leak-kinds=definite,indirect,possible",
           f"--suppressions={TESTS / 'suppressions.supp'}", "-q", str(exe)]
    res = subprocess.run(cmd, capture_output=True, text=True, env=clean_env(), timeout=900)
    check_output(res)
