"""The relation metric of Kümmerle et al. 2009 ("On measuring the accuracy of SLAM algorithms"):
for each relation (t1, t2, delta) of a relations file, the error between the estimated relative pose
of the scans at t1 and t2 and delta; reported as mean and standard deviation of the absolute
translational (m) and rotational (deg) errors, and of their squares, as the metric's tools do.

Trajectories are TUM files ('t x y z qx qy qz qw', rrr_slam_offline --trajectory); relations files
are 't1 t2 x y z roll pitch yaw' (the slamevaluation .relations files). Timestamps are matched
exactly (within `tolerance` seconds): both come from the log's ipc_timestamp.
"""

import bisect
import math
from dataclasses import dataclass
from typing import List, Tuple

import numpy as np

from .graph_io import GraphFileError, Pose, between, tagged_lines


@dataclass
class RelationError:
    count: int            # relations scored
    missing: int          # relations whose timestamps are not in the trajectory
    trans_mean: float     # m
    trans_std: float
    rot_mean_deg: float
    rot_std_deg: float
    trans_sq_mean: float  # m^2
    rot_sq_mean_deg2: float


def _numeric_rows(path: str, layout: str):
    """(line, floats) of every row of `path`, which must have the fields named in `layout`."""
    count = len(layout.split())
    for number, f in tagged_lines(path):
        if len(f) != count:
            raise GraphFileError(path, number, f"expected {count} fields '{layout}', found {len(f)}")
        try:
            yield number, [float(v) for v in f]
        except ValueError as e:
            raise GraphFileError(path, number, str(e)) from None


def read_tum(path: str) -> Tuple[List[float], List[Pose]]:
    """Stamps and (x, y, yaw) of a TUM trajectory, in file order."""
    stamps, poses = [], []
    for _, (t, x, y, _, qx, qy, qz, qw) in _numeric_rows(path, "t x y z qx qy qz qw"):
        stamps.append(t)
        poses.append((x, y, math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))))
    return stamps, poses


def read_relations(path: str) -> List[Tuple[float, float, Pose]]:
    return [(t1, t2, (x, y, yaw))
            for _, (t1, t2, x, y, _, _, _, yaw) in _numeric_rows(path, "t1 t2 x y z roll pitch yaw")]


def _index(stamps: List[float]) -> Tuple[List[float], List[int]]:
    order = sorted(range(len(stamps)), key=lambda k: stamps[k])
    return [stamps[k] for k in order], order


def _lookup(sorted_stamps, order, t, tolerance):
    i = bisect.bisect_left(sorted_stamps, t - tolerance)
    if i < len(sorted_stamps) and abs(sorted_stamps[i] - t) <= tolerance:
        return order[i]
    return None


def relation_error(stamps: List[float], poses: List[Pose], relations, tolerance: float = 1e-3) -> RelationError:
    sorted_stamps, order = _index(stamps)
    trans, rot = [], []
    missing = 0
    for t1, t2, delta in relations:
        i = _lookup(sorted_stamps, order, t1, tolerance)
        j = _lookup(sorted_stamps, order, t2, tolerance)
        if i is None or j is None:
            missing += 1
            continue
        estimate = between(poses[i], poses[j])
        e = between(delta, estimate)
        trans.append(math.hypot(e[0], e[1]))
        rot.append(abs(math.degrees(e[2])))

    trans, rot = np.array(trans), np.array(rot)

    def mean_std(v):
        return (float(v.mean()), float(v.std())) if v.size else (math.nan, math.nan)

    tm, ts = mean_std(trans)
    rm, rs = mean_std(rot)
    return RelationError(len(trans), missing, tm, ts, rm, rs, mean_std(trans ** 2)[0], mean_std(rot ** 2)[0])
