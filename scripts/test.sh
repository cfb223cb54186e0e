#!/usr/bin/env bash
# Installs what is missing, checks formatting, builds, and runs every test: the gtests and pytest,
# the gtests again built with AddressSanitizer + UndefinedBehaviorSanitizer in a second
# workspace, and the file readers' fuzz targets for a bounded time (scripts/fuzz).
# The last line is catkin_test_results' summary of the normal build.
# Usage: scripts/test.sh [--no-sanitize]
# Environment: RRR_FUZZ_SECONDS, seconds of fuzzing per target (default 60; 0 skips it).
source "$(dirname "$0")/common.sh"
rrr_install_missing

sanitize=1
[[ "${1:-}" == "--no-sanitize" ]] && sanitize=0

echo "[rrr] clang-format check"
(cd "${RRR_REPO}" && git ls-files '*.cpp' '*.h' | xargs clang-format-14 --dry-run --Werror) ||
  { echo "[rrr] formatting differs from .clang-format: run clang-format-14 -i on the files above"; exit 1; }

# Runs every test of the sourced workspace in the current folder and judges the results. The
# test targets are built first, so a compile error fails here. `catkin_make run_tests` records
# each test's result (a failing or crashing test included) and exits 0 for failed tests, so its
# status says nothing: catkin_test_results does, and a run that counted fewer tests than its floor
# ($1, a key of test/minimum_tests) fails too.
# Results of earlier runs are removed first, so a test that no longer runs cannot pass on them.
rrr_run_tests() {
  rm -rf build/test_results
  catkin_make tests >/dev/null || { echo "[rrr] building the tests failed"; return 1; }
  # Its output is filtered to the test lines; its own status still counts (a target that fails
  # to build or run), and grep finding no line is not a failure.
  catkin_make run_tests 2>&1 | { grep -E '^\[ +(RUN|OK|FAILED|PASSED) +\]|Failure|error' || true; }
  [[ ${PIPESTATUS[0]} == 0 ]] || { echo "[rrr] catkin_make run_tests failed"; return 1; }
  local summary status=0
  summary=$(catkin_test_results build/test_results) || status=$?
  [[ $status != 0 ]] && catkin_test_results build/test_results --verbose | grep -vE '^Summary' || true
  echo "${summary}" | tail -n 1
  [[ $status == 0 ]] || return 1
  rrr_enough_tests "$(echo "${summary}" | tail -n 1)" "$1"
}

if [[ $sanitize == 1 ]]; then
  echo "[rrr] sanitizer build (ASan + UBSan) of the core tests"
  (
    RRR_WS=${RRR_WS}_asan RRR_CMAKE_ARGS="-DRRR_SANITIZE=ON" rrr_build >/dev/null
    # libgomp keeps its thread pool alive at exit; leak checks would only report that.
    export ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
    cd "${RRR_WS}_asan"
    rrr_run_tests sanitizer >sanitizer_tests.log 2>&1 || { tail -n 80 sanitizer_tests.log; exit 1; }
    tail -n 1 sanitizer_tests.log
  ) || { echo "[rrr] sanitizer tests failed"; exit 1; }
fi

# Before the normal build's tests, so that their summary stays the last line. scripts/fuzz exits
# 1 on a finding (after printing its input and the reproducer), 2 when it cannot build or run.
fuzz_seconds=${RRR_FUZZ_SECONDS:-60}
if [[ "${fuzz_seconds}" != 0 ]]; then
  echo "[rrr] fuzzing each file reader for ${fuzz_seconds} s (libFuzzer, ASan + UBSan)"
  fuzz_status=0
  "${RRR_REPO}/scripts/fuzz" --all "${fuzz_seconds}" || fuzz_status=$?
  if [[ $fuzz_status == 1 ]]; then
    echo "[rrr] fuzzing found a bug: input and reproducer above (test/fuzz/README.md)"
    exit 1
  elif [[ $fuzz_status != 0 ]]; then
    echo "[rrr] building or running the fuzz targets failed"
    exit 1
  fi
fi

rrr_build >/dev/null
cd "${RRR_WS}"
rrr_run_tests all
