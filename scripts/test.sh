#!/usr/bin/env bash
# Installs what is missing, checks formatting, builds, and runs every test: the gtests, pytest and
# rostest, the gtests again built with AddressSanitizer + UndefinedBehaviorSanitizer in a second
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

if [[ $sanitize == 1 ]]; then
  echo "[rrr] sanitizer build (ASan + UBSan) of the gtests"
  (
    # The gtests and the libraries they link, nothing else (the tools, the node and the benches
    # are not run here: pytest and rostest run in the normal build).
    RRR_WS=${RRR_WS}_asan RRR_CMAKE_ARGS="-DRRR_SANITIZE=ON" rrr_build tests >/dev/null
    # libgomp keeps its thread pool alive at exit; leak checks would only report that.
    export ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
    cd "${RRR_WS}_asan"
    rrr_run_tests sanitizer run_tests_rrr_graphslam_gtest >sanitizer_tests.log 2>&1 ||
      { tail -n 80 sanitizer_tests.log; exit 1; }
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
