# Sourced by demo.sh, test.sh and the bench scripts: installs the Debian 12 packages that are
# missing, builds the catkin workspace and sources it. Not meant to be run directly.
#
# Environment: RRR_WS (catkin workspace, default ~/.cache/rrr_graphslam/ws: outside the source
# tree, since a workspace inside it would let rosrun/rospack crawl it through the src symlink),
# RRR_SKIP_INSTALL=1,
# RRR_CMAKE_ARGS (extra arguments for catkin_make), OPENBLAS_CORETYPE (see rrr_blas_kernel).

set -euo pipefail
# pyenv's python3 lacks catkin_pkg/rospkg: Debian's tools must come first.
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:${PATH}
export ROSCONSOLE_STDOUT_LINE_BUFFERED=1

RRR_REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
RRR_WS=${RRR_WS:-${XDG_CACHE_HOME:-${HOME}/.cache}/rrr_graphslam/ws}

RRR_APT_PACKAGES=(
  build-essential cmake catkin python3-catkin-pkg python3-rospkg
  ros-core-dev libnodeletlib-dev libnodeletlib-tools libtf2-ros-dev libmessage-filters-dev libtf2-eigen-dev
  python3-roslaunch python3-rostest python3-rosbag rosbash python3-rospy
  libstd-srvs-dev python3-std-srvs python3-geometry-msgs python3-nav-msgs python3-sensor-msgs
  python3-visualization-msgs python3-tf2-msgs python3-rosgraph-msgs libnav-msgs-dev
  libsensor-msgs-dev libvisualization-msgs-dev rviz librviz-dev xvfb x11-apps imagemagick
  libmrpt-graphslam-dev libmrpt-slam-dev libmrpt-maps-dev libmrpt-ros1bridge-dev mrpt-apps
  libsuitesparse-dev liblapack-dev libopenblas0-serial libeigen3-dev libboost-math-dev zlib1g-dev
  libgtest-dev googletest clang-format-14 clang-14 libclang-rt-14-dev
  python3-numpy python3-scipy python3-matplotlib python3-pytest
)

# Whether catkin_test_results' summary line $1 counts at least the tests of floor $2, a key of
# test/minimum_tests (RRR_MINIMUM_TESTS: another floors file); says why not. A run that counts
# fewer lost tests on the way (a target no longer built, a pytest file no longer collected).
rrr_enough_tests() {
  local floors=${RRR_MINIMUM_TESTS:-${RRR_REPO}/test/minimum_tests} minimum ran
  minimum=$(awk -v key="$2" '$1 == key { print $2 }' "${floors}")
  [[ -n "${minimum}" ]] || { echo "[rrr] ${floors} has no line for '$2'"; return 1; }
  ran=$(echo "$1" | sed -nE 's/^Summary: ([0-9]+) tests.*/\1/p')
  if [[ -z "${ran}" || "${ran}" -lt "${minimum}" ]]; then
    echo "[rrr] ${ran:-no} tests ran, fewer than the ${minimum} of ${floors} ($2)"
    return 1
  fi
}

# Runs every test of the sourced workspace in the current folder and judges the results. The
# test targets are built first, so a compile error fails here. `catkin_make run_tests` records
# each test's result (a failing or crashing test included) and exits 0 for failed tests, so its
# status says nothing: catkin_test_results does, and a run that counted fewer tests than its floor
# ($1, a key of test/minimum_tests) fails too. $2: the catkin target that runs them (default
# run_tests: every test; run_tests_rrr_graphslam_gtest: the gtests alone).
# Results of earlier runs are removed first, so a test that no longer runs cannot pass on them.
rrr_run_tests() {
  local run_target=${2:-run_tests}
  rm -rf build/test_results
  catkin_make tests >/dev/null || { echo "[rrr] building the tests failed"; return 1; }
  # Its output is filtered to the test lines; its own status still counts (a target that fails
  # to build or run), and grep finding no line is not a failure.
  catkin_make "${run_target}" 2>&1 | { grep -E '^\[ +(RUN|OK|FAILED|PASSED) +\]|Failure|error' || true; }
  [[ ${PIPESTATUS[0]} == 0 ]] || { echo "[rrr] catkin_make ${run_target} failed"; return 1; }
  local summary status=0
  summary=$(catkin_test_results build/test_results) || status=$?
  echo "${summary}" | tail -n 1
  if [[ $status != 0 ]]; then
    # Which tests failed, and why, before the run fails.
    catkin_test_results build/test_results --verbose | grep -vE '^Summary' || true
    echo "[rrr] tests failed"
    return 1
  fi
  rrr_enough_tests "$(echo "${summary}" | tail -n 1)" "$1"
}

rrr_install_missing() {
  [[ "${RRR_SKIP_INSTALL:-0}" == 1 ]] && return 0
  local missing=()
  for p in "${RRR_APT_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [[ ${#missing[@]} -eq 0 ]] && return 0
  echo "[rrr] installing ${#missing[@]} missing packages: ${missing[*]}"
  local sudo=()
  [[ $(id -u) -ne 0 ]] && sudo=(sudo)
  "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -q
  "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}"
}

# OpenBLAS runs its generic kernel (Prescott) on processors newer than itself (Debian 12's 0.3.21
# on Intel Emerald Rapids): CHOLMOD's large factorizations then run up to 1.5x slower, and the tools
# warn (core/blas_kernel.h). Where the processor has AVX2 and FMA, the scripts choose the Haswell
# kernel instead, so the benchmarks measure the product on a BLAS configured as the warning asks.
rrr_blas_kernel() {
  [[ -n "${OPENBLAS_CORETYPE:-}" ]] && return 0
  local core
  core=$(/usr/bin/python3 -c 'import ctypes
name = ctypes.CDLL("libopenblas.so.0").openblas_get_corename
name.restype = ctypes.c_char_p
print(name().decode())' 2>/dev/null) || return 0
  if [[ "${core}" == Prescott ]] && grep -qw avx2 /proc/cpuinfo && grep -qw fma /proc/cpuinfo; then
    export OPENBLAS_CORETYPE=Haswell
    echo "[rrr] OpenBLAS does not know this processor (kernel ${core}): OPENBLAS_CORETYPE=Haswell" >&2
  fi
}

rrr_build() {
  mkdir -p "${RRR_WS}/src"
  # make compares times only: objects built from another checkout can look newer than this
  # checkout's sources (a copy that kept its files' times, an older edit), so a workspace that
  # last built another checkout is rebuilt from scratch.
  local repo stamp="${RRR_WS}/.rrr_graphslam_checkout"
  repo=$(cd "${RRR_REPO}" && pwd -P)
  if [[ -f "${stamp}" && "$(cat "${stamp}")" != "${repo}" ]]; then
    echo "[rrr] ${RRR_WS} last built $(cat "${stamp}"): building from scratch"
    rm -rf "${RRR_WS}/build" "${RRR_WS}/devel"
  fi
  echo "${repo}" > "${stamp}"
  ln -sfn "${RRR_REPO}" "${RRR_WS}/src/rrr_graphslam"
  echo "[rrr] building in ${RRR_WS}"
  (cd "${RRR_WS}" && catkin_make -DCMAKE_BUILD_TYPE=Release ${RRR_CMAKE_ARGS:-} "$@")
  # shellcheck disable=SC1091
  set +u; source "${RRR_WS}/devel/setup.bash"; set -u
  rrr_blas_kernel
}
