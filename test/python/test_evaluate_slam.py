"""scripts/evaluate_slam: revisit selection, the ATE, and the scan-consistency check end to end on
a synthetic log (a robot driving two laps of a ray-cast room): the true trajectory is consistent
with its scans and sides with itself as the reference; a trajectory whose second lap is shifted
is flagged at every revisit the scans can tell.

The end-to-end tests need the rrr_align_scans binary (RRR_ALIGN_SCANS, passed by the build)."""
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from conftest import SCRIPTS
from rrr_graphslam.evaluate_slam import (CheckParams, Revisit, absolute_trajectory_error,
                                         evaluate, path_length, select_revisits)
from rrr_graphslam.graph_io import compose

ALIGN = os.environ.get("RRR_ALIGN_SCANS")
needs_binary = pytest.mark.skipif(not ALIGN, reason="rrr_align_scans not given")

# A 12 m x 8 m room with an inner wall and a box (segments), as test/frontend/synthetic_room.h.
WALLS = [((0, 0), (12, 0)), ((12, 0), (12, 8)), ((12, 8), (0, 8)), ((0, 8), (0, 0)),
         ((4, 0), (4, 3)), ((7, 5), (9, 5)), ((9, 5), (9, 6.5)), ((9, 6.5), (7, 6.5)),
         ((7, 6.5), (7, 5)), ((2, 6), (3, 7))]


def cast(pose, beams=180):
    """FLASER ranges from `pose`: beams from -90 degrees, pi / beams apart."""
    out = []
    for k in range(beams):
        a = pose[2] - math.pi / 2 + k * math.pi / beams
        d = np.array([math.cos(a), math.sin(a)])
        best = 30.0
        for p, q in WALLS:
            p, q = np.array(p, float), np.array(q, float)
            e = q - p
            denom = d[0] * e[1] - d[1] * e[0]
            if abs(denom) < 1e-12:
                continue
            w = p - np.array(pose[:2])
            t = (w[0] * e[1] - w[1] * e[0]) / denom
            u = (w[0] * d[1] - w[1] * d[0]) / denom
            if t > 0 and 0 <= u <= 1:
                best = min(best, t)
        out.append(best)
    return out


def two_laps(step=0.25):
    """Poses every `step` m along a 5 m x 2.3 m rectangle, twice, heading along the path."""
    corners = [(5.5, 1.5), (10.5, 1.5), (10.5, 3.8), (5.5, 3.8)]
    poses = []
    for _ in range(2):
        for (x0, y0), (x1, y1) in zip(corners, corners[1:] + corners[:1]):
            n = int(round(math.hypot(x1 - x0, y1 - y0) / step))
            heading = math.atan2(y1 - y0, x1 - x0)
            poses += [(x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n, heading) for k in range(n)]
    return poses


def flaser(ranges, pose, t):
    return ("FLASER %d %s %.6f %.6f %.6f %.6f %.6f %.6f %.6f nohost %.6f\n"
            % (len(ranges), " ".join(f"{r:.3f}" for r in ranges), *pose, *pose, 100.0 + t, t))


def write_tum(path, poses):
    with open(path, "w") as f:
        for k, (x, y, th) in enumerate(poses):
            f.write(f"{100.0 + k:.6f} {x:.6f} {y:.6f} 0 0 0 {math.sin(th / 2):.9f} "
                    f"{math.cos(th / 2):.9f}\n")


@pytest.fixture(scope="module")
def room_log(tmp_path_factory):
    folder = tmp_path_factory.mktemp("room")
    poses = two_laps()
    log = folder / "room.clf"
    log.write_text("".join(flaser(cast(p), p, float(k)) for k, p in enumerate(poses)))
    truth = folder / "truth.txt"
    write_tum(truth, poses)
    half = len(poses) // 2
    bent = folder / "bent.txt"
    write_tum(bent, poses[:half] + [compose((0.6, 0.0, 0.0), p) for p in poses[half:]])
    return folder, log, truth, bent, poses


def test_path_length_skips_unplaced_scans():
    assert path_length([(0, 0, 0), None, (3, 4, 0), (3, 5, 1)]) == [0.0, 0.0, 5.0, 6.0]


def test_revisits_pair_later_scans_with_the_nearest_earlier_one_far_along_the_path():
    poses = two_laps()
    half = len(poses) // 2
    pairs = select_revisits(poses, CheckParams(every_m=2.0, min_travel_m=10.0, radius_m=0.3))
    assert pairs, "the second lap revisits the first"
    for a, b in pairs:
        assert a < half <= b and a == b - half  # the same place one lap (14.6 m) earlier
    later = [b for _, b in pairs]
    assert all(path_length(poses)[q] - path_length(poses)[p] >= 2.0 - 1e-9
               for p, q in zip(later, later[1:]))
    # Nothing is a revisit within one lap, nor across a turn of more than max_turn_deg.
    assert select_revisits(poses, CheckParams(min_travel_m=20.0)) == []
    turned = poses[:half] + [(x, y, th + math.pi) for x, y, th in poses[half:]]
    assert select_revisits(turned, CheckParams(radius_m=0.3)) == []


def test_ate_is_zero_for_a_moved_copy_and_the_offset_of_a_shifted_half():
    poses = two_laps()
    moved = [compose((3.0, -2.0, 1.1), p) for p in poses]
    ate = absolute_trajectory_error(moved, poses)
    assert ate.rmse_m < 1e-9 and ate.scans == len(poses)
    half = len(poses) // 2
    shifted = poses[:half] + [(x + 0.4, y, th) for x, y, th in poses[half:]]
    ate = absolute_trajectory_error(shifted, poses)
    assert ate.rmse_m == pytest.approx(0.2, abs=0.01)  # half the scans 0.2 m off each way


def test_a_revisit_is_inconsistent_only_when_the_scans_prefer_the_aligned_pose():
    p = CheckParams()
    r = Revisit(0, 1, (0.5, 0.0, 0.0), aligned=(0.0, 0.0, 0.0), overlap_estimate=0.2,
                overlap_aligned=0.8)
    assert r.inconsistent(p)
    r.overlap_estimate = 0.75  # a corridor: both overlap alike
    assert not r.inconsistent(p)
    r = Revisit(0, 1, (0.1, 0.0, math.radians(2)), aligned=(0.0, 0.0, 0.0),
                overlap_estimate=0.2, overlap_aligned=0.8)
    assert not r.inconsistent(p)
    r.estimate = (0.0, 0.0, math.radians(4))
    assert r.inconsistent(p)
    assert not Revisit(0, 1, (0.5, 0.0, 0.0)).inconsistent(p)  # not aligned


@needs_binary
def test_the_true_trajectory_is_consistent_with_its_scans(room_log):
    _, log, truth, _, _ = room_log
    e = evaluate(str(log), str(truth), ALIGN, corrected=str(log))
    assert e.scans == e.placed == len(two_laps())
    assert len(e.revisits) >= 5 and len(e.aligned()) == len(e.revisits)
    assert e.inconsistent(CheckParams()) == []
    assert e.ate.rmse_m < 1e-3 and e.off_reference(CheckParams()) == []
    for r in e.revisits:
        assert r.error(r.aligned)[0] < 0.05 and r.overlap_aligned > 0.8


@needs_binary
def test_a_bent_trajectory_is_flagged_and_the_scans_side_with_the_reference(room_log):
    _, log, _, bent, poses = room_log
    e = evaluate(str(log), str(bent), ALIGN, corrected=str(log))
    bad = e.inconsistent(CheckParams())
    assert len(bad) >= 0.8 * len(e.revisits) >= 4
    for r in bad:
        assert r.error(r.aligned)[0] == pytest.approx(0.6, abs=0.05)
        assert r.error(r.reference)[0] == pytest.approx(0.6, abs=0.05)
    off = e.off_reference(CheckParams())
    assert len(off) == len(e.revisits)
    assert all(r.overlap_reference > r.overlap_estimate + 0.3 for r in off)
    assert e.ate.rmse_m == pytest.approx(0.3, abs=0.02)


@needs_binary
def test_the_script_lists_the_inconsistent_revisits(room_log):
    _, log, _, bent, _ = room_log
    result = subprocess.run([sys.executable, os.path.join(SCRIPTS, "evaluate_slam"), str(log),
                             str(bent), "--align-scans", ALIGN, "--list"],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    count = int(next(line for line in lines if line.startswith("inconsistent")).split()[1])
    listed = lines[lines.index(next(x for x in lines if x.startswith("# inconsistent"))) + 1:]
    assert count >= 4 and len(listed) == count
    assert "ATE" not in result.stdout


def test_the_script_reports_a_missing_log():
    result = subprocess.run([sys.executable, os.path.join(SCRIPTS, "evaluate_slam"),
                             "/nonexistent.clf", "/nonexistent.txt"], capture_output=True, text=True)
    assert result.returncode == 1 and "evaluate_slam:" in result.stderr
