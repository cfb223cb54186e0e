"""Multi-session benchmark (scripts/bench_sessions, issue 19): a CARMEN log split by time into N
sessions, each later one mapped by `rrr_slam_offline --load-map` from the map the previous one
saved, its odometry moved by a random SE(2) (seeded); beside it the same log mapped in one run.

Per session it reports when the session was tied to the map (the tool's `relocalized` line) and
when it entered mapped space (its first node whose ground-truth position lies within
`--mapped-radius` of a node of an earlier session), the inter-session loops RRR accepted and how
many of them are false (their measurement disagrees with the ground truth by more than
`--false-m` or `--false-deg`), the load and save times the tool prints, the map file's size
against the gzipped log, and, where a relations file exists (ACES), the relation error of
Kümmerle et al. 2009 over all relations and over those whose two scans lie in different sessions.

Ground truth for loops and for "mapped space": the corrected logs of ple_corrected (GMapping-
corrected poses of a subset of the scans, matched to the raw log's scans by their identical range
readings); a scan between two corrected ones is moved from each by the motion the one-run map
estimated between them (the raw odometry where it has none: ACES's odometry turns by up to 14
degrees more or less than the corrected poses between two corrected scans), and the two blended
(GroundTruth).

Every scan's pose for the relation error: a session loaded from a map is in the map as its nodes
only (the tool's --trajectory has one line per node for it). Its other scans are placed as the tool
places a scan (the pose of its node composed with its offset from that node), with the offset from
the session's own run (its --session-trajectory, refined, against its --output node poses), on the
node's pose in the later map. The relation error of the tool's --trajectory as written (nodes of
loaded sessions only) is reported as well.

Prints a Markdown table."""

import argparse
import bisect
import gzip
import math
import os
import random
import re
import subprocess
import sys
from collections import defaultdict
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

from .carmen import read_carmen, write_moved_log
from .decision_stream import StreamRow, read_decision_stream
from .evaluation import read_decisions
from .graph_io import Pose, between, compose, normalize_angle, open_text, read_graph
from .relations import RelationError, read_relations, read_tum, relation_error

# name: (log, relations file or None, corrected log)
LOGS = {
    "aces": ("aces.clf.gz", "aces.relations", "aces-corrected.log.gz"),
    "intel": ("intel.clf.gz", None, "intel-corrected.log.gz"),
}
LASER_TAGS = ("FLASER", "ROBOTLASER1")


# ---------------------------------------------------------------------------------------------
# Splitting a log into sessions


def random_transforms(seed: int, count: int, max_shift_m: float = 100.0) -> List[Pose]:
    """One SE(2) per session: the identity for the first, then uniform in +-max_shift_m and
    [-pi, pi) (Python's random, seeded: the same seed gives the same transforms)."""
    rng = random.Random(seed)
    out = [(0.0, 0.0, 0.0)]
    for _ in range(1, count):
        out.append((rng.uniform(-max_shift_m, max_shift_m), rng.uniform(-max_shift_m, max_shift_m),
                    normalize_angle(rng.uniform(-math.pi, math.pi))))
    return out


def message_time(fields: Sequence[str]) -> Optional[float]:
    """The logger_timestamp (last field: seconds since the log's start, monotonic where the
    ipc_timestamp is not, as in Intel) of a message line; None for comments and unstamped lines."""
    if not fields or fields[0].startswith("#") or len(fields) < 4:
        return None
    try:
        t = float(fields[-1])
        float(fields[-3])
    except ValueError:
        return None
    return t if math.isfinite(t) else None


def split_lines(lines: Sequence[str], count: int) -> List[List[str]]:
    """The log's lines in `count` parts of equal duration (by logger_timestamp; a part never goes
    back to an earlier one). Comments and PARAM lines before the first data message are copied to
    the top of every part; other lines go to the part of the message before them."""
    header, body = [], []
    first_message = None
    for k, line in enumerate(lines):
        fields = line.split()
        is_data = fields and not fields[0].startswith("#") and fields[0] != "PARAM" and \
            message_time(fields) is not None
        if first_message is None and not is_data:
            header.append(line)
        else:
            if first_message is None:
                first_message = k
            body.append(line)
    times = [t for t in (message_time(line.split()) for line in body) if t is not None]
    parts: List[List[str]] = [list(header) for _ in range(count)]
    if not times:
        parts[0].extend(body)
        return parts
    t0, span = times[0], max(times) - times[0]
    part = 0
    for line in body:
        t = message_time(line.split())
        if t is not None and span > 0:
            part = max(part, min(count - 1, int((t - t0) / span * count)))
        parts[part].append(line)
    return parts


def write_sessions(log: str, out_dir: str, count: int, seed: int) -> Tuple[List[str], List[Pose]]:
    """Writes out_dir/part_K.clf (plain CARMEN) for K < count, each seen from its odometry frame
    (carmen.write_moved_log; timestamps as logged)."""
    with open_text(log) as f:
        lines = f.readlines()
    transforms = random_transforms(seed, count)
    paths = []
    for k, (part, transform) in enumerate(zip(split_lines(lines, count), transforms)):
        path = os.path.join(out_dir, f"part_{k}.clf")
        with open(path + ".tmp", "w") as f:
            f.writelines(part)
        if transform != (0.0, 0.0, 0.0):
            write_moved_log(path + ".tmp", path + ".moved", transform)
            os.replace(path + ".moved", path + ".tmp")
        os.replace(path + ".tmp", path)
        paths.append(path)
    return paths, transforms


def gzipped_size(path: str) -> int:
    with open(path, "rb") as f:
        return len(gzip.compress(f.read(), compresslevel=9, mtime=0))


# ---------------------------------------------------------------------------------------------
# Ground truth


@dataclass
class RawScan:
    ipc: float
    logger: float
    odom: Pose
    ranges: Tuple[float, ...]


def read_raw_scans(path: str) -> List[RawScan]:
    """The laser scans of a CARMEN log, in log order."""
    return [RawScan(r.timestamp, r.logger_timestamp, r.odom_pose, tuple(r.ranges))
            for r in read_carmen(path).lasers]


def read_corrected(path: str) -> List[Tuple[float, Pose, Tuple[float, ...]]]:
    """(logger timestamp, corrected laser pose, ranges) of every scan of a ple_corrected log."""
    return [(r.logger_timestamp, r.laser_pose, tuple(r.ranges)) for r in read_carmen(path).lasers]


class StampIndex:
    """Nearest-stamp lookup within a tolerance (stamps in any order, as Intel's)."""

    def __init__(self, stamps: Sequence[float]):
        self.order = sorted(range(len(stamps)), key=lambda k: stamps[k])
        self.sorted = [stamps[k] for k in self.order]

    def find(self, t: float, tolerance: float = 1e-3) -> Optional[int]:
        i = bisect.bisect_left(self.sorted, t)
        best = None
        for j in (i - 1, i):
            if 0 <= j < len(self.sorted) and abs(self.sorted[j] - t) <= tolerance:
                if best is None or abs(self.sorted[j] - t) < abs(self.sorted[best] - t):
                    best = j
        return None if best is None else self.order[best]


class GroundTruth:
    """Ground-truth pose of every raw scan. At the corrected scans, the corrected pose. A scan
    between two corrected scans a and b (log order) is moved from each by the motion between them
    (`local`: a trajectory with a pose per raw scan, e.g. the log mapped in one run, whose motion
    over the few seconds between corrected scans is right to centimetres; the raw odometry where
    it has no pose) and the two are blended by the share of the motion (distance + 0.5 m per
    radian of turn) done since a; before the first or after the last corrected scan, moved from
    it."""

    def __init__(self, raw: Sequence[RawScan], corrected: Sequence[Tuple[float, Pose, Tuple[float, ...]]],
                 local: Optional[Sequence[Optional[Pose]]] = None):
        self.raw = list(raw)
        self.local = list(local) if local is not None else [None] * len(self.raw)
        by_ranges: Dict[Tuple[float, ...], List[int]] = defaultdict(list)
        for i, s in enumerate(self.raw):
            by_ranges[s.ranges].append(i)
        anchors = {}  # raw index -> corrected pose
        for t, pose, ranges in corrected:
            same = by_ranges.get(ranges)
            if not same:
                continue
            anchors[min(same, key=lambda k: abs(self.raw[k].logger - t))] = pose
        if not anchors:
            raise ValueError("no corrected scan matches a scan of the log")
        self.matched = len(anchors)
        self.anchor_index = sorted(anchors)
        self.anchor_pose = [anchors[i] for i in self.anchor_index]
        self.progress = [0.0]  # cumulative motion along the log
        for i in range(1, len(self.raw)):
            d = self._motion(i - 1, i)
            self.progress.append(self.progress[-1] + math.hypot(d[0], d[1]) + 0.5 * abs(d[2]))
        self.ipc = StampIndex([s.ipc for s in self.raw])

    def _motion(self, a: int, i: int) -> Pose:
        if self.local[a] is not None and self.local[i] is not None:
            return between(self.local[a], self.local[i])
        return between(self.raw[a].odom, self.raw[i].odom)

    def _from_anchor(self, j: int, i: int) -> Pose:
        return compose(self.anchor_pose[j], self._motion(self.anchor_index[j], i))

    def pose_of_scan(self, i: int) -> Pose:
        k = bisect.bisect_right(self.anchor_index, i)  # anchors before i: [0, k)
        if k == 0:
            return self._from_anchor(0, i)
        if k == len(self.anchor_index) or self.anchor_index[k - 1] == i:
            return self._from_anchor(k - 1, i)
        a, b = self.anchor_index[k - 1], self.anchor_index[k]
        total = self.progress[b] - self.progress[a]
        w = (self.progress[i] - self.progress[a]) / total if total > 0 else (i - a) / (b - a)
        fa, fb = self._from_anchor(k - 1, i), self._from_anchor(k, i)
        return ((1 - w) * fa[0] + w * fb[0], (1 - w) * fa[1] + w * fb[1],
                normalize_angle(fa[2] + w * normalize_angle(fb[2] - fa[2])))

    def pose(self, ipc: float) -> Optional[Pose]:
        i = self.ipc.find(ipc)
        return None if i is None else self.pose_of_scan(i)

    def bridge(self, i: int) -> float:
        """The motion (m, plus 0.5 m per radian of turn) between scan i and the nearest corrected
        scan: how far pose_of_scan(i) rests on `local` (or the odometry) rather than the
        corrected poses; 0 at a corrected scan."""
        k = bisect.bisect_left(self.anchor_index, i)
        return min(abs(self.progress[i] - self.progress[self.anchor_index[j]])
                   for j in (k - 1, k) if 0 <= j < len(self.anchor_index))


def local_from_trajectory(raw: Sequence[RawScan], stamps: Sequence[float],
                          poses: Sequence[Pose]) -> List[Optional[Pose]]:
    """The trajectory's pose of every raw scan (None where it has none)."""
    index = StampIndex(stamps)
    out = []
    for s in raw:
        k = index.find(s.ipc)
        out.append(None if k is None else poses[k])
    return out


def pose_error(measured: Pose, truth: Pose) -> Tuple[float, float]:
    """(m, deg) between a relative pose and the true one."""
    e = between(truth, measured)
    return math.hypot(e[0], e[1]), abs(math.degrees(e[2]))


# ---------------------------------------------------------------------------------------------
# The tools' outputs


@dataclass
class RunSummary:
    scans: int = 0
    nodes: int = 0
    time_s: float = math.nan
    candidates: int = 0
    accepted: int = 0
    load_s: float = math.nan
    save_s: float = math.nan
    relocalized: Optional[str] = None    # "at" (node), "final" (only by the final decision), "no";
    tied_node: Optional[int] = None      # None: not a loaded session. tied_node: the session's node
    tied_after_s: float = math.nan
    crossing_accepted: Optional[int] = None  # the last session's accepted loops to other sessions
    text: str = ""


def parse_summary(text: str) -> RunSummary:
    """The figures of rrr_slam_offline's summary."""
    def number(pattern, cast=float, default=math.nan):
        m = re.search(pattern, text, re.M)
        return cast(m.group(1)) if m else default
    s = RunSummary(text=text)
    s.scans = number(r"^log\s+.*: (\d+) scans", int, 0)
    s.nodes = number(r"^nodes\s+(\d+)", int, 0)
    s.time_s = number(r"^time\s+([0-9.]+) s")
    s.candidates = number(r"^candidates\s+(\d+)", int, 0)
    s.accepted = number(r"^accepted\s+(\d+)", int, 0)
    s.load_s = number(r"^loaded map\s+.* in ([0-9.]+) s")
    s.save_s = number(r"^saved map\s+.* in ([0-9.]+) s")
    m = re.search(r"^relocalized\s+at node (\d+) \(the session's node (\d+), ([0-9.]+) s after", text, re.M)
    if m:
        s.relocalized, s.tied_node, s.tied_after_s = "at", int(m.group(2)), float(m.group(3))
    elif re.search(r"^relocalized\s+only by the final decision", text, re.M):
        s.relocalized = "final"
    elif re.search(r"^relocalized\s+no", text, re.M):
        s.relocalized = "no"
    crossing = re.findall(r"^session .*: \d+ nodes, \d+ edges, (\d+) accepted loops to other sessions",
                          text, re.M)
    if crossing:
        s.crossing_accepted = int(crossing[-1])
    return s


@dataclass
class MapInfo:
    values: Dict[str, str]
    session_nodes: List[int]

    @property
    def nodes(self) -> int:
        return int(self.values["nodes"])

    @property
    def bytes(self) -> int:
        return int(self.values["bytes"])

    def first_nodes(self) -> List[int]:
        out, total = [], 0
        for n in self.session_nodes:
            out.append(total)
            total += n
        return out


def parse_map_info(text: str) -> MapInfo:
    values, sessions = {}, []
    for line in text.splitlines():
        f = line.split()
        if len(f) >= 4 and f[0] == "session" and f[2] == "nodes":
            sessions.append(int(f[3]))
        elif len(f) >= 2 and f[0] not in ("param", "session"):
            values[f[0]] = f[1]
    return MapInfo(values, sessions)


def session_of_node(first_nodes: Sequence[int]):
    def of(node: int) -> int:
        return bisect.bisect_right(first_nodes, node) - 1
    return of


@dataclass
class Loop:
    source: int
    target: int
    measurement: Pose


def accepted_loops(graph_path: str, decisions_path: str) -> List[Loop]:
    """The accepted candidates with their measurements (decided_loops)."""
    return [loop for loop, verdict in decided_loops(graph_path, decisions_path) if verdict == "accepted"]


def decided_loops(graph_path: str, decisions_path: str) -> List[Tuple[Loop, str]]:
    """Every candidate with its measurement and verdict (candidate_loops, those found)."""
    return [(loop, verdict) for loop, verdict in candidate_loops(graph_path, decisions_path)
            if loop is not None]


def candidate_loops(graph_path: str, decisions_path: str) -> List[Tuple[Optional[Loop], str]]:
    """Per RRR candidate (the decisions table's rows, in candidate order) its measurement and
    verdict: each decision row (from, to) takes the graph's edge between the same nodes,
    candidates after odometry (the graph lists odometry first), so a candidate between consecutive
    node ids is not taken for odometry; None where the graph has no such edge."""
    graph = read_graph(graph_path)
    edges: Dict[Tuple[int, int], List] = defaultdict(list)
    for e in graph.edges:
        edges[(e.source, e.target)].append(e)
    rows = read_decisions(decisions_path)
    used: Dict[Tuple[int, int], int] = defaultdict(int)
    counts: Dict[Tuple[int, int], int] = defaultdict(int)
    for d in rows:
        counts[(d.source, d.target)] += 1
    out = []
    for d in rows:
        key = (d.source, d.target)
        same = edges.get(key, [])
        # the candidates are the last counts[key] edges between these nodes
        k = len(same) - counts[key] + used[key]
        used[key] += 1
        out.append((Loop(d.source, d.target, same[k].measurement) if 0 <= k < len(same) else None,
                    d.verdict))
    return out


@dataclass
class LoopCheck:
    inter_session: int = 0        # loops between different sessions
    inter_session_false: int = 0
    checked: int = 0              # loops with ground truth at both ends
    false: int = 0                # of those, disagreeing with it
    unknown: int = 0              # loops an end of which has no ground truth
    worst: List[Tuple[float, float, int, int]] = field(default_factory=list)


def check_loops(loops: Sequence[Loop], node_stamps: Sequence[float], session_of, truth,
                max_m: float, max_deg: float, involving: Optional[int] = None) -> LoopCheck:
    """Scores loops (accepted ones, or every candidate) against `truth(stamp) -> Pose or None`;
    inter-session ones are those whose ends lie in different sessions (and, if `involving` is
    given, one of them in it)."""
    out = LoopCheck()
    for loop in loops:
        a, b = session_of(loop.source), session_of(loop.target)
        inter = a != b and (involving is None or involving in (a, b))
        ta, tb = truth(node_stamps[loop.source]), truth(node_stamps[loop.target])
        if ta is None or tb is None:
            out.unknown += 1
            out.inter_session += inter
            continue
        m, deg = pose_error(loop.measurement, between(ta, tb))
        bad = m > max_m or deg > max_deg
        out.checked += 1
        out.false += bad
        out.inter_session += inter
        out.inter_session_false += inter and bad
        if bad:
            out.worst.append((m, deg, loop.source, loop.target))
    out.worst.sort(reverse=True)
    return out


def online_false_accepts(rows: Sequence[StreamRow], known_false: Sequence[bool],
                         end_nodes: int) -> Tuple[int, int]:
    """What the robot saw of the false loops (`known_false`, per candidate) as the run decided
    online (the stream's online rows; the decision from scratch at the end is the final table's):
    how many of them were accepted at some moment, and for how many nodes (up to `end_nodes`, the
    graph's at the end) at least one of them was. That union is what a robot's map carried;
    decision_stream.score_stream times each false candidate on its own instead (a sum over
    candidates, for the per-link targets), and counts the final decision's changes too."""
    ever, accepted = set(), set()
    nodes_with, since = 0, 0
    for r in rows:
        if r.final or r.candidate >= len(known_false) or not known_false[r.candidate]:
            continue
        before = bool(accepted)
        if r.verdict == "accepted":
            accepted.add(r.candidate)
            ever.add(r.candidate)
        else:
            accepted.discard(r.candidate)
        if not before and accepted:
            since = r.nodes
        elif before and not accepted:
            nodes_with += r.nodes - since
    if accepted:
        nodes_with += end_nodes - since
    return len(ever), nodes_with


def known_false_loops(loops: Sequence[Optional[Loop]], node_stamps: Sequence[float], session_of, truth,
                      max_m: float, max_deg: float, involving: int) -> List[bool]:
    """Per candidate: whether it joins session `involving` to another one and disagrees with the
    ground truth (check_loops' test); False where unknown."""
    out = []
    for loop in loops:
        if loop is None or max(loop.source, loop.target) >= len(node_stamps):
            out.append(False)
            continue
        check = check_loops([loop], node_stamps, session_of, truth, max_m, max_deg, involving)
        out.append(check.inter_session_false > 0)
    return out


def session_components(loops: Sequence[Loop], session_of, sessions: int) -> List[List[int]]:
    """The sessions joined by the accepted loops into connected parts of the map."""
    parent = list(range(sessions))

    def root(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a
    for loop in loops:
        parent[root(session_of(loop.source))] = root(session_of(loop.target))
    parts: Dict[int, List[int]] = defaultdict(list)
    for s in range(sessions):
        parts[root(s)].append(s)
    return sorted(parts.values())


def mapped_space_entry(node_positions: Sequence[Optional[Tuple[float, float]]], first: int, end: int,
                       radius_m: float) -> Optional[int]:
    """The session's node (index from its first node) at which the session [first, end) first comes
    within radius_m of a node of an earlier session (nodes before `first`); None if never."""
    inside = mapped_space_nodes(node_positions, first, end, radius_m)
    return inside[0] if inside else None


def mapped_space_nodes(node_positions: Sequence[Optional[Tuple[float, float]]], first: int, end: int,
                       radius_m: float) -> List[int]:
    """The session's nodes (indices from its first node) of [first, end) that lie within radius_m
    of a node of an earlier session (nodes before `first`): the session in mapped space, which it
    may leave and enter again."""
    earlier = [p for p in node_positions[:first] if p is not None]
    inside: List[int] = []
    if not earlier:
        return inside
    cell = radius_m
    grid: Dict[Tuple[int, int], List[Tuple[float, float]]] = defaultdict(list)
    for p in earlier:
        grid[(math.floor(p[0] / cell), math.floor(p[1] / cell))].append(p)
    for k in range(first, end):
        p = node_positions[k]
        if p is None:
            continue
        cx, cy = math.floor(p[0] / cell), math.floor(p[1] / cell)
        near = False
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for q in grid.get((cx + dx, cy + dy), ()):
                    if math.hypot(p[0] - q[0], p[1] - q[1]) <= radius_m:
                        near = True
                        break
        if near:
            inside.append(k - first)
    return inside


def place_scans(session_stamps: Sequence[float], session_poses: Sequence[Pose],
                node_stamps: Sequence[float], node_poses_then: Sequence[Pose],
                node_poses_now: Sequence[Pose]) -> List[Pose]:
    """A loaded session's scans in a later map: each scan (in log order, as its run's
    --session-trajectory lists them) belongs to the newest of the session's nodes at or before
    it (a node's own scan carries the node's stamp), and keeps its offset from that node."""
    out = []
    node = 0
    for t, pose in zip(session_stamps, session_poses):
        if node + 1 < len(node_stamps) and abs(node_stamps[node + 1] - t) < 5e-7:
            node += 1
        offset = between(node_poses_then[node], pose)
        out.append(compose(node_poses_now[node], offset))
    return out


def cross_relations(relations, session_of_stamp) -> list:
    """The relations whose two scans lie in different sessions (both known)."""
    out = []
    for r in relations:
        a, b = session_of_stamp(r[0]), session_of_stamp(r[1])
        if a is not None and b is not None and a != b:
            out.append(r)
    return out


# ---------------------------------------------------------------------------------------------
# Running the tools


@dataclass
class Criteria:
    false_m: float = 0.5        # an accepted loop is false beyond this ...
    false_deg: float = 10.0     # ... or this, against the ground truth
    mapped_radius: float = 1.0  # m: a node is in mapped space this close to an earlier session's node


class Tools:
    def __init__(self, slam: str, map_info: str, extra: Sequence[str], reuse: bool):
        self.slam, self.map_info, self.extra, self.reuse = slam, map_info, list(extra), reuse

    def run_slam(self, log: str, out_dir: str, stem: str, args: Sequence[str]) -> RunSummary:
        """rrr_slam_offline LOG ARGS; its stdout is kept as STEM.out (reused with --reuse)."""
        summary = os.path.join(out_dir, stem + ".out")
        if self.reuse and os.path.exists(summary):
            with open(summary) as f:
                return parse_summary(f.read())
        cmd = [self.slam, log, "--quiet"] + list(args) + self.extra
        print("  " + " ".join(os.path.basename(c) if k < 2 else c for k, c in enumerate(cmd)),
              file=sys.stderr)
        result = subprocess.run(cmd, capture_output=True, text=True)
        if result.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed:\n{result.stderr}")
        with open(summary + ".tmp", "w") as f:
            f.write(result.stdout)
        os.replace(summary + ".tmp", summary)
        return parse_summary(result.stdout)

    def info(self, path: str) -> MapInfo:
        result = subprocess.run([self.map_info, path], capture_output=True, text=True)
        if result.returncode != 0:
            raise RuntimeError(f"rrr_map_info {path} failed:\n{result.stderr}")
        return parse_map_info(result.stdout)


def run_files(out_dir: str, stem: str) -> Dict[str, str]:
    return {k: os.path.join(out_dir, f"{stem}{v}") for k, v in dict(
        graph=".g2o", decisions=".tsv", trajectory=".traj.txt", session=".session.txt",
        map=".rrrmap", probe=".probe.txt", stream=".stream.tsv").items()}


def probe(tools: Tools, log: str, out_dir: str, stem: str,
          map_path: str) -> Tuple[RunSummary, List[float], List[Pose]]:
    """Loads a map with one scan of `log` as a new session: the load time, and the stamp and map
    pose of every node of the map (the first lines of --trajectory; no tool prints node stamps)."""
    files = run_files(out_dir, stem)
    s = tools.run_slam(log, out_dir, stem + ".probe", ["--load-map", map_path, "--max-scans", "1",
                                                       "--trajectory", files["probe"]])
    stamps, poses = read_tum(files["probe"])
    return s, stamps, poses


@dataclass
class SessionRow:
    log: str
    sessions: int
    seed: Optional[int]
    session: Optional[int]          # None: the single run
    summary: RunSummary
    map_bytes: int
    gzipped_log_bytes: int
    nodes: int = 0                  # the session's (single: the run's)
    entry_node: Optional[int] = None
    mapped_nodes: List[int] = field(default_factory=list)  # the session's nodes in mapped space
    loops: Optional[LoopCheck] = None
    proposed: Optional[LoopCheck] = None  # every candidate between the session and an earlier one
    # false inter-session loops accepted at some moment online, nodes with one (None: no stream)
    online_false: Optional[Tuple[int, int]] = None
    all_error: Optional[RelationError] = None
    cross_error: Optional[RelationError] = None
    nodes_only_error: Optional[RelationError] = None
    transform: Optional[Pose] = None
    load_s: float = math.nan        # of the map this session started from (single: of its map)
    save_s: float = math.nan
    final_load_s: float = math.nan  # last session: of the map it saved
    final_loops: Optional[LoopCheck] = None  # last session: every accepted loop of the final map
    final_components: Optional[List[List[int]]] = None


def fmt_error(e: Optional[RelationError]) -> str:
    if e is None:
        return "–"
    if e.count == 0:
        return "(0)"
    return f"{e.trans_mean:.4f} ± {e.trans_std:.4f} m / {e.rot_mean_deg:.2f}° ({e.count})"


def fmt_row(r: SessionRow) -> str:
    s = r.summary
    if r.session is None:
        what, reloc, entry, after, inside = "one run", "–", "–", "–", "–"
    else:
        what = f"{r.session + 1} of {r.sessions}"
        if r.session == 0:
            reloc, entry, after, inside = "(first)", "–", "–", "–"
        else:
            reloc = {"at": f"node {s.tied_node} ({s.tied_after_s:.1f} s)", "final": "at the end",
                     "no": "no"}.get(s.relocalized, "?")
            entry = "never" if r.entry_node is None else f"node {r.entry_node}"
            after = (f"{s.tied_node - r.entry_node}" if s.relocalized == "at" and r.entry_node is not None
                     else "–")
            inside = (f"{sum(1 for n in r.mapped_nodes if n < s.tied_node)}"
                      if s.relocalized == "at" and r.entry_node is not None else "–")
    loops = "–" if r.loops is None or r.session in (None, 0) else \
        f"{r.loops.inter_session} ({r.loops.inter_session_false})"
    proposed = "–" if r.proposed is None or r.session in (None, 0) else \
        f"{r.proposed.inter_session} ({r.proposed.inter_session_false})"
    online = "–" if r.online_false is None or r.session in (None, 0) else \
        f"{r.online_false[0]} ({r.online_false[1]})"
    ratio = r.map_bytes / r.gzipped_log_bytes if r.gzipped_log_bytes else math.nan
    seed = "–" if r.seed is None else str(r.seed)
    return (f"| {r.log} | {r.sessions if r.session is not None else 1} | {seed} | {what} | "
            f"{s.scans} / {r.nodes} | {s.time_s:.1f} | {reloc} | {entry} | {after} | {inside} | {proposed} | "
            f"{online} | {loops} | "
            f"{'–' if math.isnan(r.load_s) else f'{r.load_s:.2f}'} | "
            f"{'–' if math.isnan(r.save_s) else f'{r.save_s:.2f}'} | "
            f"{r.map_bytes / 1e6:.2f} MB ({ratio:.2f}×) | {fmt_error(r.all_error)} | "
            f"{fmt_error(r.cross_error)} |")


HEADER = ("| log | sessions | seed | session | scans / nodes | time (s) | relocalized at the session's "
          "node (s after start) | entered mapped space | nodes from entry to tie | nodes in mapped space "
          "before the tie | inter-session candidates proposed (false) | false inter-session loops accepted "
          "online (nodes with one) | inter-session loops "
          "accepted at the end of its run (false) | load (s) | save (s) | map file (× gzipped log) | "
          "relation error, all (relations) | relation error, cross-session (relations) |")


def find(name: str, dirs: Sequence[str]) -> Optional[str]:
    for d in dirs:
        for sub in ("", "slamevaluation", "ple_corrected"):
            path = os.path.join(d, sub, name)
            if os.path.exists(path):
                return path
    return None


class LogData:
    def __init__(self, name: str, dirs: Sequence[str]):
        file, relations, corrected = LOGS[name]
        self.name = name
        self.log = find(file, dirs)
        if self.log is None:
            raise FileNotFoundError(f"{file} not found in {list(dirs)}")
        rel = find(relations, dirs) if relations else None
        self.relations = read_relations(rel) if rel else None
        cor = find(corrected, dirs)
        if cor is None:
            raise FileNotFoundError(f"{corrected} not found in {list(dirs)}")
        self.raw = read_raw_scans(self.log)
        self.corrected = read_corrected(cor)
        self.truth = GroundTruth(self.raw, self.corrected)  # odometry between corrected scans

    def use_local_motion(self, trajectory: str):
        """Ground truth moved between corrected scans by this trajectory's motion."""
        local = local_from_trajectory(self.raw, *read_tum(trajectory))
        self.truth = GroundTruth(self.raw, self.corrected, local)


def log_data_or_skip(name: str, dirs: Sequence[str]) -> Optional[LogData]:
    """The log's LogData, or None (said on stderr) when one of its files is missing."""
    try:
        return LogData(name, dirs)
    except FileNotFoundError as e:
        print(f"{name}: {e}; skipped", file=sys.stderr)
        return None


def session_of_stamp_from_parts(parts: Sequence[str]):
    """stamp -> the part whose FLASER lines hold it (None if none)."""
    stamps, sessions = [], []
    for k, path in enumerate(parts):
        for s in read_raw_scans(path):
            stamps.append(s.ipc)
            sessions.append(k)
    index = StampIndex(stamps)

    def of(t: float) -> Optional[int]:
        i = index.find(t)
        return None if i is None else sessions[i]
    return of


def run_single(tools: Tools, data: LogData, cache: str, criteria: Criteria) -> Tuple[SessionRow, str]:
    """The log mapped in one run (its map saved and loaded again for the times); the ground truth
    takes this run's motion between corrected scans from here on."""
    out = os.path.join(cache, data.name, "single")
    os.makedirs(out, exist_ok=True)
    f = run_files(out, "run")
    s = tools.run_slam(data.log, out, "run", ["--output", f["graph"], "--decisions", f["decisions"],
                                               "--trajectory", f["trajectory"], "--save-map", f["map"]])
    info = tools.info(f["map"])
    data.use_local_motion(f["trajectory"])
    p, node_stamps, _ = probe(tools, data.log, out, "run", f["map"])
    loops = check_loops(accepted_loops(f["graph"], f["decisions"]), node_stamps,
                        session_of_node([0]), data.truth.pose, criteria.false_m, criteria.false_deg)
    row = SessionRow(data.name, 1, None, None, s, info.bytes, os.path.getsize(data.log), s.nodes,
                     loops=loops, load_s=p.load_s, save_s=s.save_s)
    if data.relations:
        row.all_error = relation_error(*read_tum(f["trajectory"]), data.relations)
    return row, f["trajectory"]


def run_sessions(tools: Tools, data: LogData, cache: str, count: int, seed: int, single_trajectory: str,
                 criteria: Criteria) -> Tuple[List[SessionRow], Optional[RelationError]]:
    """The log in `count` sessions: a row per session (the map as its run left it), and the one
    run's relation error over this split's cross-session relations."""
    out = os.path.join(cache, data.name, f"{count}_sessions_seed{seed}")
    os.makedirs(out, exist_ok=True)
    parts, transforms = write_sessions(data.log, out, count, seed)
    session_of_stamp = session_of_stamp_from_parts(parts)
    gz = [gzipped_size(p) for p in parts]
    files = [run_files(out, f"s{k}") for k in range(count)]
    summaries, infos = [], []
    for k in range(count):
        f = files[k]
        args = ["--output", f["graph"], "--decisions", f["decisions"], "--trajectory", f["trajectory"],
                "--session-trajectory", f["session"], "--save-map", f["map"], "--session-name", f"s{k}",
                "--decision-stream", f["stream"]]
        if k > 0:
            args += ["--load-map", files[k - 1]["map"]]
        summaries.append(tools.run_slam(parts[k], out, f"s{k}", args))
        infos.append(tools.info(f["map"]))
    last_probe, last_stamps, _ = probe(tools, parts[0], out, f"s{count - 1}", files[-1]["map"])

    rows = []
    for k in range(count):
        info = infos[k]
        first_nodes = info.first_nodes()
        of_node = session_of_node(first_nodes)
        # Node stamps of the map after run k: the loaded nodes of run k+1, or the probe's.
        stamps = (read_tum(files[k + 1]["trajectory"])[0] if k + 1 < count else last_stamps)[:info.nodes]
        truth = data.truth.pose
        positions = []
        for t in stamps:
            p = truth(t)
            positions.append(None if p is None else (p[0], p[1]))
        end = first_nodes[k] + info.session_nodes[k]
        inside = mapped_space_nodes(positions, first_nodes[k], end, criteria.mapped_radius) if k else []
        entry = inside[0] if inside else None
        candidates = candidate_loops(files[k]["graph"], files[k]["decisions"])
        decided = [(loop, verdict) for loop, verdict in candidates if loop is not None]
        accepted = [loop for loop, verdict in decided if verdict == "accepted"]
        loops = check_loops(accepted, stamps, of_node, truth, criteria.false_m, criteria.false_deg, involving=k)
        proposed = check_loops([loop for loop, _ in decided], stamps, of_node, truth, criteria.false_m,
                               criteria.false_deg, involving=k)
        row = SessionRow(data.name, count, seed, k, summaries[k], info.bytes, sum(gz[:k + 1]),
                         info.session_nodes[k], entry_node=entry, mapped_nodes=inside, loops=loops,
                         proposed=proposed, transform=transforms[k],
                         load_s=summaries[k].load_s if k else math.nan, save_s=summaries[k].save_s)
        if k and os.path.exists(files[k]["stream"]):  # runs kept from before the stream have none
            known_false = known_false_loops([loop for loop, _ in candidates], stamps, of_node, truth,
                                            criteria.false_m, criteria.false_deg, k)
            row.online_false = online_false_accepts(read_decision_stream(files[k]["stream"]),
                                                    known_false, info.nodes)
        if data.relations:
            t_stamps, t_poses = read_tum(files[k]["trajectory"])
            loaded = first_nodes[k]  # run k's trajectory: the loaded nodes first, then its scans
            all_stamps, all_poses = list(t_stamps[loaded:]), list(t_poses[loaded:])
            for j in range(k):
                lo, hi = first_nodes[j], first_nodes[j] + info.session_nodes[j]
                s_stamps, s_poses = read_tum(files[j]["session"])
                then = read_graph(files[j]["graph"]).poses
                all_stamps += s_stamps
                all_poses += place_scans(s_stamps, s_poses, stamps[lo:hi],
                                         [then[n] for n in range(lo, hi)], t_poses[lo:hi])
            row.all_error = relation_error(all_stamps, all_poses, data.relations)
            row.cross_error = relation_error(all_stamps, all_poses,
                                             cross_relations(data.relations, session_of_stamp))
            row.nodes_only_error = relation_error(t_stamps, t_poses, data.relations)
        if k == count - 1:
            row.final_loops = check_loops(accepted, stamps, of_node, truth, criteria.false_m, criteria.false_deg)
            row.final_components = session_components(accepted, of_node, count)
        rows.append(row)

    # The same log in one run, on this split's cross-session relations.
    single = None
    if data.relations and single_trajectory:
        st, sp = read_tum(single_trajectory)
        single = relation_error(st, sp, cross_relations(data.relations, session_of_stamp))
    rows[-1].final_load_s = last_probe.load_s
    return rows, single


def final_note(name: str, count: int, seed: int, rows: Sequence[SessionRow]) -> str:
    last, final = rows[-1], rows[-1].final_loops
    transforms = ", ".join(f"({t[0]:.1f}, {t[1]:.1f}, {math.degrees(t[2]):.0f}°)"
                           for t in (r.transform for r in rows[1:]))
    worst = ", ".join(f"{m:.2f} m {d:.1f}° {a}-{b}" for m, d, a, b in final.worst[:3])
    joined = " ".join("{" + ",".join(str(k + 1) for k in c) + "}" for c in last.final_components)
    note = (f"{name}, {count} sessions, seed {seed}: transforms {transforms}; final map loaded in "
            f"{last.final_load_s:.2f} s; its accepted loops {final.checked + final.unknown}, "
            f"{final.false} beyond the threshold{f' ({worst})' if worst else ''}, inter-session "
            f"{final.inter_session} ({final.inter_session_false} false); sessions joined: {joined}")
    if last.nodes_only_error is not None:
        note += (f"; the tool's --trajectory as written (loaded sessions: nodes only): "
                 f"{fmt_error(last.nodes_only_error)}")
    return note


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--slam-offline", required=True)
    parser.add_argument("--map-info", required=True)
    parser.add_argument("--data", action="append", required=True,
                        help="folders holding the logs, relations and corrected logs (searched with "
                             "their slamevaluation/ and ple_corrected/ subfolders)")
    parser.add_argument("--cache", required=True, help="working folder")
    parser.add_argument("--logs", nargs="*", default=list(LOGS), choices=list(LOGS))
    parser.add_argument("--sessions", nargs="*", type=int, default=[2, 4])
    parser.add_argument("--seeds", nargs="*", type=int, default=[1])
    parser.add_argument("--false-m", type=float, default=0.5, help="a loop is false beyond this (m)")
    parser.add_argument("--false-deg", type=float, default=10.0, help="... or this (degrees)")
    parser.add_argument("--mapped-radius", type=float, default=1.0,
                        help="a node is in mapped space this close (m) to an earlier session's node")
    parser.add_argument("--reuse", action="store_true", help="reuse the runs kept in --cache")
    parser.add_argument("extra", nargs=argparse.REMAINDER, help="-- then options for rrr_slam_offline")
    args = parser.parse_args(argv)
    criteria = Criteria(args.false_m, args.false_deg, args.mapped_radius)
    tools = Tools(args.slam_offline, args.map_info, [a for a in args.extra if a != "--"], args.reuse)

    lines = [HEADER, "|" + "---|" * HEADER.count(" | ") + "---|"]
    notes = []
    for name in args.logs:
        data = log_data_or_skip(name, args.data)
        if data is None:
            continue
        print(f"{name}: one run ...", file=sys.stderr)
        odometry_truth = data.truth
        single_row, single_traj = run_single(tools, data, args.cache, criteria)
        if data.relations:
            def truth_error(truth):
                poses = [truth.pose_of_scan(i) for i in range(len(data.raw))]
                return fmt_error(relation_error([s.ipc for s in data.raw], poses, data.relations))
            notes.append(f"{name}: ground truth from {data.truth.matched} corrected scans; its relation error "
                         f"{truth_error(data.truth)} (with the raw odometry between corrected scans: "
                         f"{truth_error(odometry_truth)})")
        else:
            notes.append(f"{name}: ground truth from {data.truth.matched} corrected scans; no relations file")
        worst = single_row.loops.worst
        notes.append(f"{name}, one run: {single_row.loops.checked} accepted loops checked against the ground "
                     f"truth, {single_row.loops.false} beyond {args.false_m} m / {args.false_deg}°"
                     + (f" (worst {worst[0][0]:.2f} m / {worst[0][1]:.1f}°)" if worst else ""))
        for count in args.sessions:
            for seed in args.seeds:
                print(f"{name}: {count} sessions, seed {seed} ...", file=sys.stderr)
                rows, single_cross = run_sessions(tools, data, args.cache, count, seed, single_traj, criteria)
                if seed == args.seeds[0]:  # the one run, on this split's cross-session relations
                    lines.append(fmt_row(SessionRow(**{**single_row.__dict__, "sessions": count,
                                                       "cross_error": single_cross})))
                lines.extend(fmt_row(r) for r in rows)
                notes.append(final_note(name, count, seed, rows))
    print("\n".join(lines))
    print()
    print("\n".join("- " + n for n in notes))
    return 0


if __name__ == "__main__":
    sys.exit(main())
