"""CARMEN log reader (FLASER, ROBOTLASER1, ODOM; plain or .gz), the laser logs of the Radish and
slamevaluation collections. ROS-free; carmen_ros.py turns the records into messages.

Conventions the logs leave implicit (see the README's data notes):
- FLASER has no angle fields: the beams span 180 degrees from -90 degrees, one degree (or half a
  degree) apart: increment pi/n for an even count (180, 360 readings), pi/(n-1) for an odd one
  (181, 361), so that the beams fall on whole or half degrees.
- "No return" is written as the sensor's maximum range; readings at or above the log's maximum
  (max_range) are misses.
- Timestamps are the ipc_timestamp field (the one relations files use); they may go backwards
  (Intel): records stay in log order and monotonic_stamps() repairs the order for ROS.
"""

import math
from dataclasses import dataclass
from typing import List, Optional, Tuple

from .graph_io import GraphFileError, Pose, between, tagged_lines, text_lines


@dataclass
class LaserRecord:
    timestamp: float        # ipc_timestamp, s
    angle_min: float        # rad, in the laser frame
    angle_increment: float  # rad
    max_range: float        # m, as stated (ROBOTLASER1) or the log's maximum reading (FLASER)
    ranges: List[float]
    laser_pose: Pose        # world (odometry) pose of the laser
    odom_pose: Pose         # odometry pose of the robot
    line: int
    logger_timestamp: float = math.nan  # the logger's own timestamp (the line's last field)


@dataclass
class OdomRecord:
    timestamp: float
    pose: Pose
    tv: float  # m/s
    rv: float  # rad/s
    line: int


@dataclass
class CarmenLog:
    path: str
    lasers: List[LaserRecord]
    odometry: List[OdomRecord]  # ODOM lines; empty for logs that have none (odometry then comes with the scans)
    records: List[object]       # both, in log order

    @property
    def max_range(self) -> float:
        return max((r.max_range for r in self.lasers), default=0.0)

    def laser_offset(self) -> Pose:
        """Laser pose in the robot frame (from the first scan)."""
        return between(self.lasers[0].odom_pose, self.lasers[0].laser_pose) if self.lasers else (0.0, 0.0, 0.0)


def flaser_increment(n: int) -> float:
    return math.pi / n if n % 2 == 0 else math.pi / (n - 1)


def read_carmen(path: str) -> CarmenLog:
    """Raises GraphFileError (file:line) for malformed FLASER/ROBOTLASER1/ODOM lines; other
    message types (PARAM, SYNC, TRUEPOS, ...) are skipped."""
    lasers: List[LaserRecord] = []
    odometry: List[OdomRecord] = []
    records: List[object] = []
    for number, fields in tagged_lines(path):
        tag = fields[0]
        if tag not in ("FLASER", "ROBOTLASER1", "ODOM"):
            continue
        try:
            record = _parse(tag, fields, number)
        except (ValueError, IndexError) as e:
            raise GraphFileError(path, number, f"malformed {tag} line: {e}") from None
        (odometry if isinstance(record, OdomRecord) else lasers).append(record)
        records.append(record)
    if not lasers:
        raise GraphFileError(path, 0, "no FLASER or ROBOTLASER1 line")
    # FLASER states no maximum: the log's largest reading is its "no return" value.
    flaser_max = max((max(r.ranges) for r in lasers if math.isnan(r.max_range)), default=0.0)
    for r in lasers:
        if math.isnan(r.max_range):
            r.max_range = flaser_max
    return CarmenLog(path, lasers, odometry, records)


def _finite(values, what):
    for v in values:
        if not math.isfinite(v):
            raise ValueError(f"{what} is not finite")
    return values


def _parse(tag: str, f: List[str], line: int):
    if tag == "ODOM":
        if len(f) < 8:
            raise ValueError(f"expected at least 8 fields, found {len(f)}")
        x, y, t, tv, rv = _finite([float(v) for v in f[1:6]], "pose or velocity")
        return OdomRecord(float(f[7]), (x, y, t), tv, rv, line)
    if tag == "FLASER":
        n = int(f[1])
        # Exactly: a count one off would read every later field one place off.
        if n < 2 or len(f) != n + 11:
            raise ValueError(f"{n} readings need {n + 11} fields, found {len(f)}")
        ranges = _finite([float(v) for v in f[2:2 + n]], "a range")
        x, y, t, ox, oy, ot = _finite([float(v) for v in f[2 + n:8 + n]], "a pose")
        return LaserRecord(float(f[8 + n]), -math.pi / 2, flaser_increment(n), math.nan, ranges,
                           (x, y, t), (ox, oy, ot), line, float(f[10 + n]))
    # ROBOTLASER1 type start fov resolution max_range accuracy remission_mode n ranges... nrem rems...
    #   laser x y theta robot x y theta tv rv forward_safety side_safety turn_axis ipc host logger
    start, fov, resolution, max_range = (float(v) for v in f[2:6])
    n = int(f[8])
    k = 9 + n
    if n < 2 or k >= len(f):
        raise ValueError(f"a reading count of {n} does not fit the line's {len(f)} fields")
    n_rem = int(f[k])
    k += 1 + n_rem
    if n_rem < 0 or len(f) != k + 14:
        raise ValueError(f"expected {k + 14} fields, found {len(f)}")
    ranges = _finite([float(v) for v in f[9:9 + n]], "a range")
    lx, ly, lt, rx, ry, rt = _finite([float(v) for v in f[k:k + 6]], "a pose")
    _finite([start, fov, resolution, max_range], "an angle or the maximum range")
    if resolution <= 0:
        raise ValueError("angular resolution must be positive")
    return LaserRecord(float(f[k + 11]), start, resolution, max_range, ranges, (lx, ly, lt), (rx, ry, rt), line,
                       float(f[k + 13]))


def monotonic_stamps(times: List[float], step: float = 1e-6) -> Tuple[List[float], int]:
    """Stamps that never go back (each at least `step` after the previous), and how many changed."""
    out: List[float] = []
    changed = 0
    for t in times:
        if out and t <= out[-1]:
            t = out[-1] + step
            changed += 1
        out.append(t)
    return out, changed


def odometry_stream(log: CarmenLog) -> List[Tuple[float, Pose, float, float]]:
    """(time, pose, tv, rv) in log order: the ODOM lines, or the scans' odometry when there are none."""
    if log.odometry:
        return [(o.timestamp, o.pose, o.tv, o.rv) for o in log.odometry]
    return [(r.timestamp, r.odom_pose, 0.0, 0.0) for r in log.lasers]


def is_miss(reading: float, max_range: Optional[float]) -> bool:
    return max_range is not None and reading >= max_range


def _motion_fields(fields: List[str]) -> Optional[Tuple[Tuple[int, ...], Tuple[int, int]]]:
    """Where a FLASER, ROBOTLASER1 or ODOM line's fields hold its poses (x y theta each) and its
    two timestamps; None for any other line."""
    tag = fields[0] if fields else ""
    if tag == "FLASER":
        n = int(fields[1])
        return (2 + n, 5 + n), (8 + n, 10 + n)
    if tag == "ROBOTLASER1":
        k = 10 + int(fields[8]) + int(fields[9 + int(fields[8])])
        return (k, k + 3), (k + 11, k + 13)
    if tag == "ODOM":
        return (1,), (7, 9)
    return None


def write_moved_log(source: str, target: str, frame: Pose, later: float = 0.0) -> None:
    """Writes the CARMEN log `source` (plain or .gz) to `target` as another run would have logged
    it: every pose of its FLASER, ROBOTLASER1 and ODOM lines seen from an odometry frame moved by
    the SE(2) `frame` (p' = frame * p) and every timestamp `later` seconds later. Other lines are
    copied. For multi-session tests and benchmarks: the same scans from an unrelated frame."""
    fx, fy, ft = frame
    c, s = math.cos(ft), math.sin(ft)
    out = []
    for _, line in text_lines(source):
        fields = line.split()
        where = _motion_fields(fields)
        if where is None:
            out.append(line + "\n")
            continue
        poses, stamps = where
        for k in poses:
            x, y, t = (float(v) for v in fields[k:k + 3])
            fields[k:k + 3] = [repr(fx + c * x - s * y), repr(fy + s * x + c * y), repr(t + ft)]
        for k in stamps:
            fields[k] = repr(float(fields[k]) + later)
        out.append(" ".join(fields) + "\n")
    with open(target, "w") as f:
        f.write("".join(out))


def write_there_and_back_log(source: str, target: str, part: str = "both") -> None:
    """Writes the CARMEN log `source` (plain or .gz) to `target` followed by its FLASER,
    ROBOTLASER1 and ODOM lines again in reverse order, timestamps mirrored after the last: the
    robot drives its path back, one session that comes back over all it saw. Other lines are
    copied once, first. For tests of a session that revisits its own path. `part` "back" writes
    the way back alone (the rest of a drive whose first part is `source`)."""
    if part not in ("both", "back"):
        raise ValueError(f"part must be both or back, not {part!r}")
    header, motion = [], []
    for _, line in text_lines(source):
        fields = line.split()
        where = _motion_fields(fields)
        if where is None:
            header.append(line)
        else:
            motion.append((fields, where[1]))
    if not motion:
        raise GraphFileError(f"{source}: no FLASER, ROBOTLASER1 or ODOM line to drive back")
    end = max(float(fields[k]) for fields, stamps in motion for k in stamps)
    back = []
    for fields, stamps in reversed(motion):
        mirrored = list(fields)
        for k in stamps:
            mirrored[k] = repr(2.0 * end + 0.05 - float(mirrored[k]))
        back.append(mirrored)
    with open(target, "w") as f:
        f.write("".join(line + "\n" for line in header))
        there = [m[0] for m in motion] if part == "both" else []
        f.write("".join(" ".join(fields) + "\n" for fields in there + back))
