#!/usr/bin/env bash
# Run the whole pytest suite against an AddressSanitizer + UndefinedBehaviorSanitizer
# build of the C core, and fail on any sanitizer report.
#
#   bash tools/sanitize.sh            # one command; about 1.5 min on 2 cores
#
# What it does:
#   1. copies the working tree (tracked and untracked, not ignored files) to a
#      scratch directory, so the in-place build of your own checkout is untouched;
#   2. creates a fresh virtualenv (default /tmp/cgbound-asan-venv, override with
#      CGBOUND_ASAN_VENV) and installs numpy, scipy, pytest, mpmath, hypothesis;
#   3. builds the extension with CGBOUND_SANITIZE=1 (setup.py then compiles with
#      -fsanitize=address,undefined -fno-sanitize-recover=undefined -O1 -g);
#   4. runs pytest with libasan preloaded (python itself is not instrumented, so
#      the ASan runtime must be loaded first) and fails if the log contains
#      "ERROR: AddressSanitizer" or "runtime error:" or if pytest fails.
#
# Extra arguments are passed to pytest (e.g. -k, -x, or -n 2: pytest-xdist is installed, and each
# worker's sanitizer reports go to their own log files, which are all checked).
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
venv="${CGBOUND_ASAN_VENV:-/tmp/cgbound-asan-venv}"
work="$(mktemp -d /tmp/cgbound-asan-src.XXXXXX)"
log="$work/pytest.log"
start=$SECONDS

# 1. a clean copy of the sources
(cd "$repo" && git ls-files -z --cached --others --exclude-standard | xargs -0 tar cf - 2>/dev/null) | (cd "$work" && tar xf -)
find "$work" -name '*.so' -delete

# 2. fresh virtualenv
rm -rf "$venv"
python3 -m venv "$venv"
# shellcheck disable=SC1091
source "$venv/bin/activate"
python -m pip install -q --upgrade pip "setuptools>=77" wheel
python -m pip install -q numpy scipy pytest pytest-xdist mpmath hypothesis h5py meshio xarray matplotlib

# 3. sanitized build (non-editable install into the venv)
export CGBOUND_SANITIZE=1
(cd "$work" && python -m pip install -q --no-build-isolation --no-deps .)

libasan="$(gcc -print-file-name=libasan.so)"
# libstdc++ is preloaded too: C++ extensions among the test dependencies throw exceptions, and
# ASan's __cxa_throw interceptor needs the real symbol to be there when it starts up
libstdcxx="$(gcc -print-file-name=libstdc++.so)"
if [ ! -e "$libasan" ]; then
    echo "sanitize.sh: gcc has no libasan.so ($libasan)" >&2
    exit 2
fi

# 4. the suite. detect_leaks=0: CPython (and numpy's caches) keep memory alive
# until exit by design, so LeakSanitizer would report thousands of "leaks" that
# are not bugs; reference leaks are covered by tests/test_refcount_leak.py and
# C-level leaks by `make -C csrc/tests valgrind`.
# halt_on_error / -fno-sanitize-recover: the first report aborts the process.
# log_path: reports go to files $work/sanitizer.<pid> as well as being
# searched for in the log, because pytest captures a test's stderr and a report
# printed just before the process aborts would otherwise be lost with it (the
# run would then only show up as a pytest failure without a reason).
set +e
(
    cd "$work"
    LD_PRELOAD="$libasan $libstdcxx" \
    ASAN_OPTIONS="detect_leaks=0:halt_on_error=1:log_path=$work/sanitizer" \
    UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:log_path=$work/sanitizer" \
    pytest -q -p no:cacheprovider "$@"
) 2>&1 | tee "$log"
status=${PIPESTATUS[0]}
set -e

reports=$(find "$work" -maxdepth 1 -name 'sanitizer.*' -size +0 | sort)
if [ -n "$reports" ]; then
    for f in $reports; do echo "---- $f"; cat "$f"; done
    echo "sanitize.sh: sanitizer report(s) found: $reports" >&2
    exit 1
fi
if grep -qE "ERROR: AddressSanitizer|runtime error:|ERROR: LeakSanitizer" "$log"; then
    echo "sanitize.sh: sanitizer report(s) found, see $log" >&2
    exit 1
fi
if [ "$status" -ne 0 ]; then
    echo "sanitize.sh: pytest failed (exit $status), see $log" >&2
    exit 1
fi
echo "sanitize.sh: no sanitizer reports, pytest passed; finished in $((SECONDS - start)) s"
rm -rf "$work"
