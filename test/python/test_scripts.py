"""The Python scripts: installed by catkin_install_python, importing the module from a sourced
workspace (PYTHONPATH) without touching sys.path or PATH themselves, and each one starts; the
floor of tests below which scripts/test.sh fails."""
import os
import re
import subprocess
import sys

import pytest
from conftest import SCRIPTS

CMAKELISTS = os.path.join(SCRIPTS, "..", "CMakeLists.txt")


def python_scripts():
    """The files in scripts/ whose first line is a Python shebang."""
    names = []
    for name in sorted(os.listdir(SCRIPTS)):
        with open(os.path.join(SCRIPTS, name), "rb") as f:
            first = f.readline()
        if first.startswith(b"#!") and b"python" in first:
            names.append(name)
    return names


PYTHON_SCRIPTS = python_scripts()


def test_the_scripts_are_found():
    assert {"add_outliers", "evaluate", "replay_posegraph", "replay_carmen", "carmen_to_bag",
            "snapshot_rviz"} <= set(PYTHON_SCRIPTS)
    assert not os.path.exists(os.path.join(SCRIPTS, "_module_path.py"))


@pytest.mark.parametrize("name", PYTHON_SCRIPTS)
def test_script_leaves_sys_path_and_path_alone(name):
    with open(os.path.join(SCRIPTS, name)) as f:
        text = f.read()
    assert "sys.path" not in text
    assert not re.search(r"""environ\[["']PATH["']\]|putenv|_module_path""", text)


def test_every_python_script_is_installed():
    with open(CMAKELISTS) as f:
        text = f.read()
    listed = re.search(r"catkin_install_python\(PROGRAMS(.*?)\sDESTINATION\s", text, re.S).group(1).split()
    assert sorted(os.path.basename(p) for p in listed) == PYTHON_SCRIPTS


def importable(module):
    return subprocess.run([sys.executable, "-c", f"import {module}"], capture_output=True).returncode == 0


@pytest.mark.parametrize("name", PYTHON_SCRIPTS)
def test_script_starts_from_the_environment(tmp_path, name):
    """--help from another folder, with the module on PYTHONPATH only (conftest: a sourced
    workspace, or this tree after it)."""
    with open(os.path.join(SCRIPTS, name)) as f:
        text = f.read()
    for module in ("rospy", "rosbag", "rrr_graphslam.msg"):
        needed = f"import {module}" in text or (module == "rrr_graphslam.msg" and "replay_ros" in text)
        if needed and not importable(module):
            pytest.skip(f"{module} is not importable here (a sourced catkin workspace provides it)")
    result = subprocess.run([sys.executable, os.path.join(SCRIPTS, name), "--help"], cwd=str(tmp_path),
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert "usage" in result.stdout


def enough_tests(tmp_path, summary, key, floors="all 10\nsanitizer 5\n"):
    """scripts/common.sh's rrr_enough_tests on a summary line, against a floors file."""
    (tmp_path / "floors").write_text(floors)
    return subprocess.run(
        ["bash", "-c", f'source {os.path.join(SCRIPTS, "common.sh")} && rrr_enough_tests "$0" "$1"',
         summary, key], env={**os.environ, "RRR_MINIMUM_TESTS": str(tmp_path / "floors")},
        capture_output=True, text=True)


def test_a_test_run_counting_fewer_tests_than_its_floor_fails(tmp_path):
    ok = "Summary: 10 tests, 0 errors, 0 failures, 0 skipped"
    assert enough_tests(tmp_path, ok, "all").returncode == 0
    assert enough_tests(tmp_path, "Summary: 6 tests, 0 errors, 0 failures, 0 skipped",
                        "sanitizer").returncode == 0
    few = enough_tests(tmp_path, "Summary: 9 tests, 0 errors, 0 failures, 0 skipped", "all")
    assert few.returncode == 1 and "9 tests ran, fewer than the 10" in few.stdout
    none = enough_tests(tmp_path, "no summary", "all")
    assert none.returncode == 1 and "no tests ran" in none.stdout
    unknown = enough_tests(tmp_path, ok, "fuzz")
    assert unknown.returncode == 1 and "has no line for 'fuzz'" in unknown.stdout


def test_the_test_floors_are_kept_for_both_runs():
    floors = dict(line.split() for line in open(os.path.join(SCRIPTS, "..", "test", "minimum_tests"))
                  if line.strip() and not line.startswith("#"))
    # The sanitizer run is the gtests alone (pytest and rostest run in the normal build only).
    assert set(floors) == {"all", "sanitizer"}
    assert int(floors["all"]) > 700 and int(floors["sanitizer"]) > 300


def run_tests_with(tmp_path, build=0, run=0, results=0, summary="Summary: 10 tests, 0 errors, 0 failures, 0 skipped",
                   target=""):
    """common.sh's rrr_run_tests with stand-ins for catkin_make (`tests` exits `build`, the run
    target, `target` or run_tests, prints its name and exits `run`) and catkin_test_results
    (prints `summary`, exits `results`)."""
    (tmp_path / "floors").write_text("all 10\n")
    script = f"""
source {os.path.join(SCRIPTS, "common.sh")}
set +e
catkin_make() {{ [[ $1 == tests ]] && return {build}; echo "[       OK ] ran.$1"; return {run}; }}
catkin_test_results() {{ echo '{summary}'; return {results}; }}
cd {tmp_path} && rrr_run_tests all {target}
"""
    return subprocess.run(["bash", "-c", script], capture_output=True, text=True,
                          env={**os.environ, "RRR_MINIMUM_TESTS": str(tmp_path / "floors")})


def test_a_failing_build_run_or_test_fails_the_test_run(tmp_path):
    assert run_tests_with(tmp_path).returncode == 0
    assert "ran.run_tests" in run_tests_with(tmp_path).stdout
    gtests = run_tests_with(tmp_path, target="run_tests_rrr_graphslam_gtest")
    assert gtests.returncode == 0 and "ran.run_tests_rrr_graphslam_gtest" in gtests.stdout
    assert "catkin_make run_tests_rrr_graphslam_gtest failed" in run_tests_with(
        tmp_path, run=2, target="run_tests_rrr_graphslam_gtest").stdout
    assert "building the tests failed" in run_tests_with(tmp_path, build=2).stdout
    assert run_tests_with(tmp_path, build=2).returncode == 1
    assert run_tests_with(tmp_path, run=2).returncode == 1
    failed = run_tests_with(tmp_path, results=1,
                            summary="Summary: 10 tests, 0 errors, 1 failures, 0 skipped")
    assert failed.returncode == 1 and "[rrr] tests failed" in failed.stdout
    few = run_tests_with(tmp_path, summary="Summary: 9 tests, 0 errors, 0 failures, 0 skipped")
    assert few.returncode == 1
