"""The command-line contract of rrr_simulate on the bundled Intel lab world: the files of every
session, their frames and dates, the changes between sessions, repeatability from the seed,
errors, and a simulated log that rrr_slam_offline maps.

The build passes the binaries' paths (RRR_SIMULATE, RRR_SLAM_OFFLINE); run by hand without them,
these tests are skipped.
"""
import math
import os
import re
import subprocess

import numpy as np
import pytest
from rrr_graphslam.carmen import read_carmen
from rrr_graphslam.evaluation import absolute_trajectory_error
from rrr_graphslam.relations import read_tum

SIMULATE = os.environ.get("RRR_SIMULATE")
SLAM_OFFLINE = os.environ.get("RRR_SLAM_OFFLINE")
needs_simulate = pytest.mark.skipif(not SIMULATE, reason="rrr_simulate not given")
WORLDS = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..",
                                       "worlds", "intel_lab"))
WORLD = os.path.join(WORLDS, "intel_lab.yaml")


def run(*args):
    return subprocess.run([str(a) for a in args], capture_output=True, text=True)


def read_pgm(path):
    """Pixels of a binary PGM as written by map_saver and rrr_simulate (one comment line)."""
    data = open(path, "rb").read()
    magic, comment, size, maximum, pixels = data.split(b"\n", 4)
    assert magic == b"P5" and comment.startswith(b"#") and maximum == b"255"
    width, height = map(int, size.split())
    return np.frombuffer(pixels, dtype=np.uint8).reshape(height, width)


def summary(stdout):
    """The 'session K key value ...' lines as {K: {key: value}}."""
    sessions = {}
    for line in stdout.splitlines():
        fields = line.split()
        if fields[0] == "session":
            sessions[int(fields[1])] = dict(zip(fields[2::2], fields[3::2]))
    return sessions


@needs_simulate
def test_two_sessions_with_their_own_frames_dates_and_worlds(tmp_path):
    out = tmp_path / "sim"
    result = run(SIMULATE, WORLD, "--sessions", 2, "--changes", os.path.join(WORLDS, "furniture.yaml"),
                 "--seed", 4, "--max-scans", 300, "--out", out)
    assert result.returncode == 0, result.stderr
    sessions = summary(result.stdout)
    assert sorted(sessions) == [0, 1]
    assert sessions[0]["changes"] == "0" and sessions[1]["changes"] == "2"
    logs, truths = [], []
    for k in (0, 1):
        name = out / f"session_{k:02d}"
        log = read_carmen(f"{name}.clf")
        stamps, poses = read_tum(f"{name}_truth.txt")
        assert len(log.lasers) == len(log.odometry) == len(stamps) == 300
        assert int(sessions[k]["scans"]) == 300
        first = log.lasers[0]
        assert len(first.ranges) == 181 and first.max_range == 30.0
        assert first.angle_min == pytest.approx(-math.pi / 2, abs=1e-6)
        assert first.angle_increment == pytest.approx(math.pi / 180, abs=1e-6)
        assert [r.timestamp for r in log.lasers] == pytest.approx(stamps, abs=1e-6)
        assert np.diff(stamps) == pytest.approx(0.2, abs=1e-6)  # 5 Hz
        # Every reading is a return (below max range, on a wall) or a miss (max range).
        assert all(0.0 < r <= 30.0 for scan in log.lasers for r in scan.ranges)
        logs.append(log)
        truths.append(poses)
    # Session 1 starts a day later, in another odometry frame.
    assert logs[1].lasers[0].timestamp - logs[0].lasers[0].timestamp == pytest.approx(86400.0)
    assert logs[0].lasers[0].odom_pose != pytest.approx(logs[1].lasers[0].odom_pose, abs=1.0)
    # The odometry moves like the truth, up to drift: the distance driven agrees within 5%.
    for log, truth in zip(logs, truths):
        odom = np.array([r.odom_pose[:2] for r in log.lasers])
        true = np.array([p[:2] for p in truth])
        driven = np.sum(np.linalg.norm(np.diff(true, axis=0), axis=1))
        assert driven > 10.0
        assert np.sum(np.linalg.norm(np.diff(odom, axis=0), axis=1)) == pytest.approx(driven, rel=0.05)
    # Session 0's world is the bundled one; session 1's has the two boxes of session 1 and no
    # other change.
    base = read_pgm(os.path.join(WORLDS, "intel_lab.pgm"))
    w0 = read_pgm(out / "session_00_world.pgm")
    w1 = read_pgm(out / "session_01_world.pgm")
    assert np.array_equal(w0, base)
    changed = w1 != base
    assert np.all(w1[changed] == 0)  # boxes added: cells became occupied
    assert 50 < np.count_nonzero(changed) <= 72 + 64  # at most the two boxes' 0.1 m cells
    world_yaml = (out / "session_01_world.yaml").read_text()
    assert "image: session_01_world.pgm" in world_yaml and "resolution: 0.1" in world_yaml


@needs_simulate
def test_change_sets_apply_together(tmp_path):
    base = read_pgm(os.path.join(WORLDS, "intel_lab.pgm"))
    changed = {}
    for name, sets in (("furniture", ["furniture"]), ("doors", ["doors"]), ("both", ["furniture", "doors"])):
        args = [a for s in sets for a in ("--changes", os.path.join(WORLDS, f"{s}.yaml"))]
        result = run(SIMULATE, WORLD, "--sessions", 2, "--max-scans", 10, "--out", tmp_path / name, *args)
        assert result.returncode == 0, result.stderr
        changed[name] = read_pgm(tmp_path / name / "session_01_world.pgm") != base
    assert changed["furniture"].any() and changed["doors"].any()
    assert np.array_equal(changed["both"], changed["furniture"] | changed["doors"])


@needs_simulate
def test_the_seed_decides_everything(tmp_path):
    def simulate(seed, folder):
        result = run(SIMULATE, WORLD, "--seed", seed, "--max-scans", 60, "--out", tmp_path / folder)
        assert result.returncode == 0, result.stderr
        return (tmp_path / folder / "session_00.clf").read_bytes()

    first = simulate(7, "a")
    assert simulate(7, "b") == first
    assert simulate(8, "c") != first


@needs_simulate
def test_bad_input_is_named(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("changes:\n  - {session: 1, kind: box, action: add, center: [1, 1], size: [1, 1]}\n"
                   "  - {session: 2, kind: box, action: paint, center: [1, 1], size: [1, 1]}\n")
    result = run(SIMULATE, WORLD, "--changes", bad, "--out", tmp_path / "out")
    assert result.returncode == 1
    assert f"{bad}:3: change 2: 'action' of a box must be add or remove, not 'paint'" in result.stderr
    assert not (tmp_path / "out").exists()
    result = run(SIMULATE, WORLD)
    assert result.returncode == 2 and "--out is required" in result.stderr
    result = run(SIMULATE, WORLD, "--out", tmp_path / "out", "--odometry-noise", "0.1,0.1")
    assert result.returncode == 2 and "--odometry-noise needs 4" in result.stderr


@needs_simulate
@pytest.mark.skipif(not SLAM_OFFLINE, reason="rrr_slam_offline not given")
def test_slam_offline_maps_a_simulated_session(tmp_path):
    out = tmp_path / "sim"
    result = run(SIMULATE, WORLD, "--seed", 2, "--max-scans", 400, "--out", out)
    assert result.returncode == 0, result.stderr
    trajectory = tmp_path / "trajectory.txt"
    result = run(SLAM_OFFLINE, out / "session_00.clf", "--trajectory", trajectory, "--quiet")
    assert result.returncode == 0, result.stderr
    assert "session_00.clf: 400 scans" in result.stdout
    stamps, estimate = read_tum(str(trajectory))
    truth_stamps, truth = read_tum(str(out / "session_00_truth.txt"))
    assert stamps == pytest.approx(truth_stamps, abs=1e-6)
    # A few centimetres after SE(2) alignment (the odometry alone drifts decimetres).
    ate = absolute_trajectory_error(dict(enumerate(estimate)), dict(enumerate(truth)))
    odometry = [r.odom_pose for r in read_carmen(str(out / "session_00.clf")).lasers]
    drift = absolute_trajectory_error(dict(enumerate(odometry)), dict(enumerate(truth)))
    assert ate < 0.05
    assert drift > 2 * ate


@pytest.mark.skipif(not (SIMULATE and SLAM_OFFLINE and os.environ.get("RRR_MAP_INFO")),
                    reason="rrr_simulate/rrr_slam_offline/rrr_map_info not given")
def test_a_trimmed_map_keeps_its_loops_when_it_is_loaded(tmp_path):
    # Two sessions, the second trimmed when saved: with odometry that drifts, the marginal edges
    # that join the sessions close cycles with the odometry that do not hold exactly (they carry
    # the loops that bent it). Loaded again, RRR must still accept the loops the trimmed map kept:
    # its joint tests measure what loops add to that residual (a build that tested the residual
    # itself rejected every one of them).
    out = tmp_path / "sim"
    assert run(SIMULATE, WORLD, "--seed", 1, "--sessions", 2, "--out", out).returncode == 0
    first, trimmed = tmp_path / "first.rrrmap", tmp_path / "trimmed.rrrmap"
    result = run(SLAM_OFFLINE, out / "session_00.clf", "--save-map", first, "--quiet", "--refine-resolution", 0)
    assert result.returncode == 0, result.stderr
    result = run(SLAM_OFFLINE, out / "session_01.clf", "--load-map", first, "--save-map", trimmed,
                 "--max-scans", 800, "--lifelong", "--quiet", "--refine-resolution", 0)
    assert result.returncode == 0, result.stderr
    trim = dict(line.split(" ", 1) for line in result.stdout.splitlines() if line.startswith("trim_"))
    assert int(trim["trim_nodes"]) > 0 and int(trim["trim_marginal_edges_kept"]) > 0, result.stdout
    info = run(os.environ["RRR_MAP_INFO"], trimmed)
    kept = int(dict(line.split(" ", 1) for line in info.stdout.splitlines())["loop_edges_accepted"])
    assert kept > 0
    again = run(SLAM_OFFLINE, out / "session_00.clf", "--load-map", trimmed, "--max-scans", 2, "--quiet",
                "--refine-resolution", 0)
    assert again.returncode == 0, again.stderr
    assert int(re.search(r"^accepted +(\d+)", again.stdout, re.M).group(1)) >= kept, again.stdout
