#!/usr/bin/env bash
# Installs what is missing, checks formatting, builds, and runs every test: the gtests and pytest,
# and the gtests again built with AddressSanitizer + UndefinedBehaviorSanitizer in a second
# workspace.
# The last line is catkin_test_results' summary of the normal build.
# Usage: scripts/test.sh [--no-sanitize]
source "$(dirname "$0")/common.sh"
rrr_install_missing

sanitize=1
[[ "${1:-}" == "--no-sanitize" ]] && sanitize=0

echo "[rrr] clang-format check"
(cd "${RRR_REPO}" && git ls-files '*.cpp' '*.h' | xargs clang-format-14 --dry-run --Werror) ||
  { echo "[rrr] formatting differs from .clang-format: run clang-format-14 -i on the files above"; exit 1; }

if [[ $sanitize == 1 ]]; then
  echo "[rrr] sanitizer build (ASan + UBSan) of the core tests"
  (
    RRR_WS=${RRR_WS}_asan RRR_CMAKE_ARGS="-DRRR_SANITIZE=ON" rrr_build >/dev/null
    # libgomp keeps its thread pool alive at exit; leak checks would only report that.
    export ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
    cd "${RRR_WS}_asan" && catkin_make run_tests >/dev/null 2>&1 || true
    catkin_test_results build/test_results | tail -n 1
    catkin_test_results build/test_results >/dev/null
  ) || { echo "[rrr] sanitizer tests failed"; exit 1; }
fi

rrr_build >/dev/null
cd "${RRR_WS}"
catkin_make run_tests 2>&1 | grep -E '^\[ +(RUN|OK|FAILED|PASSED) +\]|Failure|error' || true
catkin_test_results build/test_results --verbose >/dev/null 2>&1 || true
catkin_test_results build/test_results
