"""g2o / TORO pose-graph files, the same formats as the C++ reader (core/graph_io.h).

Information matrices are kept in g2o order (xx xy xt yy yt tt); TORO files store
xx xy yy tt xt yt and are converted on reading and writing. Files may be gzip-compressed.
Every malformed line raises GraphFileError naming the file and line.
"""

import gzip
import math
import os
import tempfile
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

G2O_ORDER = (0, 1, 2, 3, 4, 5)
# Position in a TORO line of each g2o-ordered entry: xx xy xt yy yt tt <- xx xy yy tt xt yt.
TORO_TO_G2O = (0, 1, 4, 2, 5, 3)

Pose = Tuple[float, float, float]  # x, y (m), theta (rad)


class GraphFileError(ValueError):
    """A malformed pose-graph file; the message starts with 'file:line:'."""

    def __init__(self, path: str, line: int, what: str):
        super().__init__(f"{path}:{line}: {what}" if line else f"{path}: {what}")
        self.path, self.line, self.what = path, line, what


@dataclass
class Edge:
    source: int
    target: int
    measurement: Pose
    information: Tuple[float, ...]  # upper triangle, g2o order
    line: int = 0

    @property
    def is_loop(self) -> bool:
        """The default marking: |from - to| != 1 is a loop candidate."""
        return abs(self.source - self.target) != 1


@dataclass
class PoseGraph:
    poses: Dict[int, Pose] = field(default_factory=dict)
    edges: List[Edge] = field(default_factory=list)

    def loops(self) -> List[Edge]:
        return [e for e in self.edges if e.is_loop]


def open_text(path: str, mode: str = "rt"):
    if path.endswith(".gz"):
        return gzip.open(path, mode)
    return open(path, mode)


def compose(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], normalize_angle(a[2] + b[2]))


def inverse(a):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (-(c * a[0] + s * a[1]), s * a[0] - c * a[1], normalize_angle(-a[2]))


def between(a, b):
    return compose(inverse(a), b)


def normalize_angle(t: float) -> float:
    t = math.remainder(t, 2.0 * math.pi)
    return math.pi if t <= -math.pi else t


def _is_positive_definite(info) -> bool:
    xx, xy, xt, yy, yt, tt = info
    m1 = xx
    m2 = xx * yy - xy * xy
    m3 = xx * (yy * tt - yt * yt) - xy * (xy * tt - yt * xt) + xt * (xy * yt - yy * xt)
    return m1 > 0 and m2 > 0 and m3 > 0


def tagged_lines(path: str):
    """(line number, fields) of every line that is not blank or a '#' comment; fields[0] is the tag."""
    with open_text(path) as f:
        for number, raw in enumerate(f, start=1):
            fields = raw.split()
            if fields and not fields[0].startswith("#"):
                yield number, fields


def read_graph(path: str, allow_disconnected: bool = True) -> PoseGraph:
    graph = PoseGraph()
    vertex_line: Dict[int, int] = {}
    for number, fields in tagged_lines(path):
        tag = fields[0]

        def fail(what, number=number):
            raise GraphFileError(path, number, what)

        def numbers(values):
            out = []
            for k, v in enumerate(values):
                try:
                    x = float(v)
                except ValueError:
                    fail(f"field {k + 1} of {tag} ('{v}') is not a number")
                if not math.isfinite(x):
                    fail(f"field {k + 1} of {tag} ('{v}') is not finite")
                out.append(x)
            return out

        def node_id(v):
            if not v.isdigit():
                fail(f"'{v}' is not a node id (a non-negative integer)")
            return int(v)

        if tag in ("VERTEX_SE2", "VERTEX2"):
            if len(fields) != 5:
                fail(f"{tag} expects 4 fields after the tag, found {len(fields) - 1}")
            i = node_id(fields[1])
            if i in vertex_line:
                fail(f"duplicate vertex id {i} (first defined on line {vertex_line[i]})")
            vertex_line[i] = number
            graph.poses[i] = tuple(numbers(fields[2:5]))
        elif tag in ("EDGE_SE2", "EDGE2"):
            if len(fields) != 12:
                fail(f"{tag} expects 11 fields after the tag, found {len(fields) - 1}")
            i, j = node_id(fields[1]), node_id(fields[2])
            if i == j:
                fail(f"self-loop: edge from node {i} to itself")
            values = numbers(fields[3:12])
            raw_info = values[3:]
            info = tuple(raw_info[k] for k in (TORO_TO_G2O if tag == "EDGE2" else G2O_ORDER))
            if not _is_positive_definite(info):
                fail(f"information matrix of {tag} is not positive definite")
            z = (values[0], values[1], normalize_angle(values[2]))
            graph.edges.append(Edge(i, j, z, info, number))
        else:
            fail(f"unknown tag '{tag}' (expected VERTEX_SE2, EDGE_SE2, VERTEX2 or EDGE2)")
    if not vertex_line:
        _chain_initial_poses(graph)
    for e in graph.edges:
        for end in (e.source, e.target):
            if end not in graph.poses:
                raise GraphFileError(path, e.line, f"edge refers to unknown node {end}")
    if not graph.poses:
        raise GraphFileError(path, 0, "no vertices or edges in the file")
    if not allow_disconnected:
        parts = components(graph)
        if len(parts) > 1:
            raise GraphFileError(path, 0, f"graph is disconnected: {len(parts)} components")
    return graph


def _chain_initial_poses(graph: PoseGraph) -> None:
    """Poses for an edges-only file: a 0-1 breadth-first search in which odometry costs nothing
    and loop candidates cost one, as in C++; a pose is final when its node leaves the queue."""
    from collections import defaultdict, deque

    incident = defaultdict(list)
    for e in graph.edges:
        incident[e.source].append(e)
        incident[e.target].append(e)
    poses, cost, done = {}, {}, set()
    for root in sorted(incident):
        if root in cost:
            continue
        poses[root], cost[root] = (0.0, 0.0, 0.0), 0
        queue = deque([root])
        while queue:
            n = queue.popleft()
            if n in done:
                continue
            done.add(n)
            for e in incident[n]:
                other = e.target if e.source == n else e.source
                if other in done:
                    continue
                through = cost[n] + (1 if e.is_loop else 0)
                if other in cost and cost[other] <= through:
                    continue
                cost[other] = through
                z = e.measurement if e.source == n else inverse(e.measurement)
                poses[other] = compose(poses[n], z)
                (queue.append if e.is_loop else queue.appendleft)(other)
    graph.poses = dict(sorted(poses.items()))


def components(graph: PoseGraph) -> List[List[int]]:
    parent = {i: i for i in graph.poses}

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for e in graph.edges:
        parent[find(e.source)] = find(e.target)
    groups: Dict[int, List[int]] = {}
    for i in sorted(graph.poses):
        groups.setdefault(find(i), []).append(i)
    return list(groups.values())


def format_number(x: float) -> str:
    return repr(float(x))


def write_graph(graph: PoseGraph, path: str, toro: Optional[bool] = None) -> None:
    """Writes atomically (temporary file + rename). TORO for .graph/.toro unless told."""
    if toro is None:
        stem = path[:-3] if path.endswith(".gz") else path
        toro = stem.endswith((".graph", ".toro"))
    lines = []
    vertex_tag, edge_tag = ("VERTEX2", "EDGE2") if toro else ("VERTEX_SE2", "EDGE_SE2")
    for i in sorted(graph.poses):
        lines.append(f"{vertex_tag} {i} " + " ".join(format_number(v) for v in graph.poses[i]))
    for e in graph.edges:
        info = e.information
        if toro:
            info = (info[0], info[1], info[3], info[5], info[2], info[4])
        values = list(e.measurement) + list(info)
        lines.append(f"{edge_tag} {e.source} {e.target} " + " ".join(format_number(v) for v in values))
    write_text_atomically(path, "\n".join(lines) + "\n")


def write_text_atomically(path: str, text: str) -> None:
    directory = os.path.dirname(os.path.abspath(path))
    fd, temp = tempfile.mkstemp(prefix=os.path.basename(path) + ".", suffix=".tmp", dir=directory)
    try:
        with os.fdopen(fd, "wb") as f:
            data = text.encode()
            f.write(gzip.compress(data, mtime=0) if path.endswith(".gz") else data)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(temp, 0o666 & ~_umask())
        os.replace(temp, path)
    except BaseException:
        if os.path.exists(temp):
            os.unlink(temp)
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
