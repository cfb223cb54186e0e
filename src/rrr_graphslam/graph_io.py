"""g2o / TORO pose-graph files, read as the C++ reader (core/graph_io.cpp) reads them.

Information matrices are kept in g2o order (xx xy xt yy yt tt); TORO files store
xx xy yy tt xt yt and are converted on reading and writing. Files may be gzip-compressed (told by
their first bytes, as zlib does, not by the name). Every malformed line raises GraphFileError
naming the file and line, with the C++ reader's message. test_graph_io_agreement.py reads every
bundled graph and the edge cases with both readers.

The C++ reader's conventions followed here: lines end at LF only (a lone CR is whitespace);
fields are split at the C locale's whitespace; numbers follow std::from_chars (no '+', no '_', a
nonzero mantissa that underflows to 0 is "not finite"); node ids are unsigned 64-bit decimal
integers; vertex angles are normalized like measurement angles.
"""

import gzip
import io
import math
import os
import re
import tempfile
import zlib
from collections import defaultdict, deque
from dataclasses import dataclass, field
from typing import Dict, Iterator, List, Optional, Tuple

import numpy as np

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
class DenseFactor:
    """A dense factor (core/dense_factor.h: the exact marginal of trimmed nodes), as the
    product's g2o files carry it: `RRR_DENSE_SE2 n id_0 .. id_{n-1} y_1 .. y_{n-1} mean
    information offset`, the information's upper triangle row by row."""
    nodes: List[int]
    measurements: List[Pose]
    mean: List[float]
    information: List[float]  # upper triangle, row by row
    offset: float
    line: int = 0


DENSE_TAG = "RRR_DENSE_SE2"


@dataclass
class PoseGraph:
    poses: Dict[int, Pose] = field(default_factory=dict)
    edges: List[Edge] = field(default_factory=list)
    dense_factors: List[DenseFactor] = field(default_factory=list)

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


def information_matrix(upper) -> np.ndarray:
    """The symmetric 3x3 information matrix of six upper-triangle values in g2o order."""
    xx, xy, xt, yy, yt, tt = upper
    return np.array([[xx, xy, xt], [xy, yy, yt], [xt, yt, tt]], dtype=float)


def information_problem(info: np.ndarray) -> str:
    """'' for a positive-definite matrix, else why not (core::informationProblem: a Cholesky
    factorization that fails, as Eigen's LLT does)."""
    try:
        np.linalg.cholesky(info)
        return ""
    except np.linalg.LinAlgError:
        values = " ".join(f"{v:.6g}" for v in np.linalg.eigvalsh(info))
        return f"the matrix is not positive definite (eigenvalues {values})"


# Whitespace to str.split() on Latin-1 text but not to std::isspace in the C locale (to which,
# as to bytes.split(), only space, \t, \n, \v, \f and \r are).
_NOT_C_SPACE = re.compile(rb"[\x1c-\x1f\x85\xa0]")
_DECIMAL = re.compile(r"-?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_NON_FINITE = re.compile(r"-?(?:inf(?:inity)?|nan(?:\([0-9A-Za-z_]*\))?)", re.IGNORECASE)
_NODE_ID = re.compile(r"[0-9]+")
_LINE_END = re.compile(rb"\r\n?|\n")


def parse_number(text: str) -> Tuple[float, str]:
    """(value, problem) of a whole field as std::from_chars reads it: problem is '' or 'not a
    number' or 'not finite' (infinities, NaNs, overflow, and a nonzero value that underflows)."""
    if _DECIMAL.fullmatch(text):
        value = float(text)
        if math.isinf(value) or (value == 0.0 and re.split("[eE]", text)[0].strip("-.0")):
            return value, "not finite"
        return value, ""
    if _NON_FINITE.fullmatch(text):
        return math.nan, "not finite"
    return math.nan, "not a number"


class _ReadError(Exception):
    pass


def _raw_lines(path: str, chunk_bytes: int = 1 << 16) -> Iterator[bytes]:
    """The file's lines without their '\\n', as core::LineReader reads them through zlib: gzip
    if the file starts with gzip's magic (whatever its name), members one after another, bytes
    after the last member ignored; a damaged or truncated stream raises _ReadError after the
    lines before the damage."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:2] != b"\x1f\x8b":
        lines = data.split(b"\n")
        yield from lines[:-1] if lines[-1] == b"" else lines
        return
    pending = b""
    while data[:2] == b"\x1f\x8b":
        inflater = zlib.decompressobj(16 + zlib.MAX_WBITS)
        start = 0
        while start < len(data) and not inflater.eof:
            try:
                pending += inflater.decompress(data[start:start + chunk_bytes])
            except zlib.error as e:
                raise _ReadError(str(e)) from None
            start += chunk_bytes
            *complete, pending = pending.split(b"\n")
            yield from complete
        if not inflater.eof:
            raise _ReadError("unexpected end of file")
        data = inflater.unused_data + data[start:]
    if pending:
        yield pending


def tagged_lines(path: str) -> Iterator[Tuple[int, List[str]]]:
    """(line number, fields) of every line that is not blank or a '#' comment; fields[0] is the
    tag. Lines end at '\\n' (a lone '\\r' is whitespace), fields are split at C whitespace, bytes
    are read as Latin-1; a damaged gzip stream raises GraphFileError ('read error'), and so does
    a NUL byte (no text file has one)."""
    number = 0
    lines = _raw_lines(path)
    while True:
        try:
            raw = next(lines)
        except StopIteration:
            return
        except _ReadError as e:
            raise GraphFileError(path, number + 1, f"read error: {e}") from None
        number += 1
        nul = raw.find(b"\0")
        if nul >= 0:
            raise GraphFileError(path, number, f"NUL byte at column {nul + 1}: not a text file")
        if _NOT_C_SPACE.search(raw):
            fields = [v.decode("latin-1") for v in raw.split()]
        else:
            fields = raw.decode("latin-1").split()
        if fields and not fields[0].startswith("#"):
            yield number, fields


def text_lines(path: str) -> Iterator[Tuple[int, str]]:
    """(line number, text without its line end) of every line of a UTF-8 text file, plain or gzip
    (told by its first bytes), split as Python's text mode splits them (at '\\n', '\\r\\n' or
    '\\r'). A damaged gzip stream, a NUL byte and bytes that are not UTF-8 raise GraphFileError
    naming the line, before any line is returned."""
    raw: List[bytes] = []
    lines = _raw_lines(path)
    while True:
        try:
            raw.append(next(lines))
        except StopIteration:
            break
        except _ReadError as e:
            raise GraphFileError(path, len(raw) + 1, f"read error: {e}") from None
    data = b"\n".join(raw)

    def fail(offset: int, what: str):
        ends = list(_LINE_END.finditer(data, 0, offset))
        column = offset - (ends[-1].end() if ends else 0) + 1
        raise GraphFileError(path, len(ends) + 1, what.format(column=column) + ": not a text file")

    nul = data.find(b"\0")
    if nul >= 0:
        fail(nul, "NUL byte at column {column}")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        fail(e.start, f"byte 0x{data[e.start]:02x} at column {{column}} is not UTF-8")
    for number, line in enumerate(io.StringIO(text, newline=None), start=1):
        yield number, line[:-1] if line.endswith("\n") else line


class _Line:
    """One tagged line's fields, read and checked as core::LineParser does."""

    def __init__(self, path: str, number: int, fields: List[str]):
        self.path, self.number, self.fields, self.tag = path, number, fields, fields[0]

    def fail(self, what: str):
        raise GraphFileError(self.path, self.number, what)

    def _field(self, k: int) -> str:
        return f"field {k} of {self.tag} ('{self.fields[k]}')"

    def expect_count(self, count: int) -> None:
        if len(self.fields) - 1 != count:
            self.fail(f"{self.tag} expects {count} fields after the tag, found {len(self.fields) - 1}")

    def node_id(self, k: int) -> int:
        v = self.fields[k]
        if not _NODE_ID.fullmatch(v) or int(v) >= 2 ** 64:
            self.fail(self._field(k) + " is not a node id (a non-negative integer)")
        return int(v)

    def numbers(self, first: int, count: int) -> List[float]:
        out = []
        for k in range(first, first + count):
            value, problem = parse_number(self.fields[k])
            if problem:
                self.fail(f"{self._field(k)} is {problem}")
            out.append(value)
        return out


def read_graph(path: str, allow_disconnected: bool = True) -> PoseGraph:
    """The graph of a g2o or TORO file (each line's tag decides). Unlike the C++ reader, whose
    tools reject disconnected graphs unless told, a disconnected graph is allowed by default."""
    graph = PoseGraph()
    vertex_line: Dict[int, int] = {}
    for number, fields in tagged_lines(path):
        line = _Line(path, number, fields)
        tag = line.tag
        if tag in ("VERTEX_SE2", "VERTEX2"):
            line.expect_count(4)
            i = line.node_id(1)
            x, y, t = line.numbers(2, 3)
            if i in vertex_line:
                line.fail(f"duplicate vertex id {i} (first defined on line {vertex_line[i]})")
            vertex_line[i] = number
            graph.poses[i] = (x, y, normalize_angle(t))
        elif tag in ("EDGE_SE2", "EDGE2"):
            line.expect_count(11)
            i, j = line.node_id(1), line.node_id(2)
            if i == j:
                line.fail(f"self-loop: edge from node {i} to itself")
            x, y, t = line.numbers(3, 3)
            raw_info = line.numbers(6, 6)
            info = tuple(raw_info[k] for k in (TORO_TO_G2O if tag == "EDGE2" else G2O_ORDER))
            problem = information_problem(information_matrix(info))
            if problem:
                line.fail(f"information matrix of {tag}: {problem}")
            graph.edges.append(Edge(i, j, (x, y, normalize_angle(t)), info, number))
        elif tag == DENSE_TAG:
            graph.dense_factors.append(_read_dense_factor(line))
        else:
            line.fail(f"unknown tag '{tag}' (expected VERTEX_SE2, EDGE_SE2, VERTEX2, EDGE2 or {DENSE_TAG})")
    if not vertex_line:
        _chain_initial_poses(graph)
    for e in graph.edges:
        for end in (e.source, e.target):
            if end not in graph.poses:
                raise GraphFileError(path, e.line, f"edge refers to unknown node {end}")
    for f in graph.dense_factors:
        for node in f.nodes:
            if node not in graph.poses:
                raise GraphFileError(path, f.line, f"dense factor refers to unknown node {node}")
    if not graph.poses:
        raise GraphFileError(path, 0, "no vertices or edges in the file")
    if not allow_disconnected:
        parts = components(graph)
        if len(parts) > 1:
            raise GraphFileError(path, 0, "graph is disconnected: " + describe_components(parts))
    return graph


def _read_dense_factor(line: "_Line") -> DenseFactor:
    """One RRR_DENSE_SE2 line, checked as core::readDenseFactor checks it."""
    if len(line.fields) < 2:
        line.fail(f"{line.tag} a node count needs at least 1 fields after the tag, found {len(line.fields) - 1}")
    count = line.node_id(1)
    if count < 2:
        line.fail(f"node count {count}: a dense factor has 2 or more")
    if count > len(line.fields):
        line.fail(f"node count {count} exceeds the line's {len(line.fields) - 1} fields")
    k = count - 1
    rows = 3 * k
    line.expect_count(1 + count + 3 * k + rows + rows * (rows + 1) // 2 + 1)
    at = 2
    nodes = [line.node_id(at + i) for i in range(count)]
    at += count
    values = line.numbers(at, len(line.fields) - at)
    measurements = [(values[3 * a], values[3 * a + 1], values[3 * a + 2]) for a in range(k)]
    mean = values[3 * k:3 * k + rows]
    upper = values[3 * k + rows:-1]
    offset = values[-1]
    if len(set(nodes)) != len(nodes):
        twice = sorted(n for n in set(nodes) if nodes.count(n) > 1)[0]
        line.fail(f"dense factor: node {twice} is listed twice")
    matrix = np.zeros((rows, rows))
    matrix[np.triu_indices(rows)] = upper
    matrix = matrix + np.triu(matrix, 1).T
    try:
        np.linalg.cholesky(matrix)
    except np.linalg.LinAlgError:
        line.fail("dense factor: its information is not positive definite")
    if offset < 0:
        line.fail(f"dense factor: its chi2 offset {offset:.6f} is not a finite value >= 0")
    return DenseFactor(nodes, measurements, mean, upper, offset, line.number)


def _chain_initial_poses(graph: PoseGraph) -> None:
    """Poses for an edges-only file: a 0-1 breadth-first search in which odometry costs nothing
    and loop candidates cost one, as in C++; a pose is final when its node leaves the queue."""
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
    """Connected components, each sorted, ordered by their smallest id."""
    parent = {i: i for i in graph.poses}

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for e in graph.edges:
        parent[find(e.source)] = find(e.target)
    for f in graph.dense_factors:
        for node in f.nodes[1:]:
            parent[find(node)] = find(f.nodes[0])
    groups: Dict[int, List[int]] = {}
    for i in sorted(graph.poses):
        groups.setdefault(find(i), []).append(i)
    return list(groups.values())


def describe_components(parts: List[List[int]]) -> str:
    """core::describeComponents: e.g. '2 components: {0..99} (100 nodes), {100,...,180} (3 nodes)'."""
    def describe(ids):
        text = "{" + str(ids[0])
        if len(ids) > 1:
            text += (".." if ids[-1] - ids[0] + 1 == len(ids) else ",...,") + str(ids[-1])
        return text + f"}} ({len(ids)} {'node' if len(ids) == 1 else 'nodes'})"

    shown = ", ".join(describe(ids) for ids in parts[:8])
    return f"{len(parts)} components: {shown}" + (", ..." if len(parts) > 8 else "")


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
    if toro and graph.dense_factors:
        raise ValueError(f"{path}: the graph holds {len(graph.dense_factors)} dense factors, which TORO "
                         "files cannot hold: nothing was written")
    for f in graph.dense_factors:
        values = [v for y in f.measurements for v in y] + list(f.mean) + list(f.information) + [f.offset]
        lines.append(f"{DENSE_TAG} {len(f.nodes)} " + " ".join(str(n) for n in f.nodes) + " " +
                     " ".join(format_number(v) for v in values))
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
