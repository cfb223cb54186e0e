"""The two readers of g2o/TORO files agree: src/core/graph_io.cpp (the reference) and
rrr_graphslam.graph_io. Each fixture, every bundled graph and the hand-made edge cases below, is
read by both: the same nodes and poses, the same edges in the same order (ends, measurement,
information to 1e-12), or the same rejection (line and message).

The C++ reader is reached through rrr_optimize with zero iterations from the file's poses, which
writes the graph it read back in g2o with every number in its shortest exact form; that output
is parsed here by a few obviously correct lines, not by the reader under test. rrr_optimize
rejects disconnected graphs (the C++ default), so the Python side reads with
allow_disconnected=False. Without RRR_OPTIMIZE only the Python side is checked against the
expected outcome of each edge case.
"""
import glob
import gzip
import math
import os
import subprocess

import pytest
from conftest import DATA
from rrr_graphslam.graph_io import GraphFileError, read_graph

OPTIMIZE = os.environ.get("RRR_OPTIMIZE")
needs_optimize = pytest.mark.skipif(not OPTIMIZE, reason="RRR_OPTIMIZE not given")

BUNDLED = sorted(p for p in glob.glob(os.path.join(DATA, "**", "*"), recursive=True)
                 if p.endswith((".g2o", ".g2o.gz", ".graph", ".graph.gz", ".toro", ".toro.gz")))

V01 = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n"
E01 = "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n"
BASE = V01 + E01
# Node 2 one metre ahead of node 1, identity information, zero mean and offset.
DENSE_12 = "RRR_DENSE_SE2 2 1 2 1 0 0 0 0 0 1 0 0 1 0 1 0\n"


def vertex(value):
    """A file whose second vertex has `value` as its x."""
    return f"VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 {value} 0 0\n" + E01


# name: (file content (str or bytes), expected: None = read, else a piece of the error message)
EDGE_CASES = {
    "comments_blank_and_indented": ("# a header\n\n \t \n  # indented comment\n" + BASE + "#\n", None),
    "crlf": (BASE.replace("\n", "\r\n"), None),
    "tabs_vt_ff_and_runs_of_spaces": ("VERTEX_SE2\t0 \v0\f0   0\nVERTEX_SE2 1 1 0 0 \t\n" + E01, None),
    "no_final_newline": (BASE.rstrip("\n"), None),
    "nbsp_is_not_whitespace": (b"VERTEX_SE2 0 0\xa00 0\n", "VERTEX_SE2 expects 4 fields after the tag, found 3"),
    "file_separator_is_not_whitespace": (b"VERTEX_SE2 0 0 0\x1c0\n", "found 3"),
    "nbsp_in_a_number": (b"VERTEX_SE2 0 0 0 \xa00\n", "field 4 of VERTEX_SE2 ('\xa00') is not a number"),
    "lone_cr_is_not_a_line_end": ("VERTEX_SE2 0 0 0 0\rVERTEX_SE2 1 1 0 0\n" + E01, "found 9"),
    "fix_line": (BASE + "FIX 0\n", "unknown tag 'FIX'"),
    "lower_case_tag": (BASE.replace("EDGE_SE2", "edge_se2"), "unknown tag 'edge_se2'"),
    "trailing_comment": (V01 + E01.rstrip("\n") + " # odometry\n", "expects 11 fields"),
    "toro": ("VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nVERTEX2 2 2 0 0\n"
             "EDGE2 0 1 1 0 0 10 1 20 30 2 3\nEDGE2 1 2 1 0 0.1 10 -1 20 30 -2 -3\n"
             "EDGE2 2 0 -2 0 0 5 0 5 5 0 0\n", None),
    "g2o_full_information": (V01 + "EDGE_SE2 0 1 1 0.5 -0.25 10 1 2 20 3 30\n", None),
    "mixed_tags": ("VERTEX_SE2 0 0 0 0\nVERTEX2 1 1 0 0\nEDGE2 0 1 1 0 0 10 1 20 30 2 3\n"
                   "EDGE_SE2 1 0 -1 0 0 10 1 2 20 3 30\n", None),
    "parallel_edges": (BASE + E01 + "EDGE_SE2 1 0 -1 0 0 1 0 0 1 0 1\n", None),
    "vertex_angles_wrapped": ("VERTEX_SE2 0 0 0 4.0\nVERTEX_SE2 1 1 0 -7\nVERTEX_SE2 2 2 0 3.141592653589793\n"
                              "VERTEX_SE2 3 3 0 -3.141592653589793\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n"
                              "EDGE_SE2 1 2 1 0 3.141592653589793 1 0 0 1 0 1\n"
                              "EDGE_SE2 2 3 1 0 9.42477796076938 1 0 0 1 0 1\n", None),
    "edges_only_chain": ("EDGE_SE2 0 3 9 9 0 1 0 0 1 0 1\n" + "".join(
        f"EDGE_SE2 {i} {i + 1} 1 0 0.3 1 0 0 1 0 1\n" for i in range(4)) + "EDGE_SE2 6 5 -1 0 -0.2 1 0 0 1 0 1\n"
        "EDGE_SE2 5 4 -1 0 0.1 1 0 0 1 0 1\n", None),
    "edges_only_through_a_loop": ("EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nEDGE_SE2 0 5 2 1 0.5 1 0 0 1 0 1\n"
                                  "EDGE_SE2 5 6 1 0 0.1 1 0 0 1 0 1\n", None),
    "edges_only_disconnected": ("EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nEDGE_SE2 5 6 1 0 0 1 0 0 1 0 1\n",
                                "disconnected: 2 components: {0..1} (2 nodes), {5..6} (2 nodes)"),
    "disconnected": ("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 5 1 0 0\nVERTEX_SE2 6 1 0 0\nVERTEX_SE2 9 1 0 0\n"
                     "EDGE_SE2 5 9 1 0 0 1 0 0 1 0 1\n",
                     "disconnected: 3 components: {0} (1 node), {5,...,9} (2 nodes), {6} (1 node)"),
    "one_vertex": ("VERTEX_SE2 7 1 2 0.5\n", None),
    "leading_zeros_in_ids": ("VERTEX_SE2 000 0 0 0\nVERTEX_SE2 01 1 0 0\nEDGE_SE2 00 001 1 0 0 1 0 0 1 0 1\n", None),
    "largest_id": ("VERTEX_SE2 18446744073709551615 0 0 0\n", None),
    "id_too_large": ("VERTEX_SE2 18446744073709551616 0 0 0\n", "is not a node id"),
    "negative_id": (BASE + "EDGE_SE2 -1 1 1 0 0 1 0 0 1 0 1\n", "field 1 of EDGE_SE2 ('-1') is not a node id"),
    "plus_id": ("VERTEX_SE2 +1 0 0 0\n", "is not a node id"),
    "fractional_id": ("VERTEX_SE2 1.0 0 0 0\n", "is not a node id"),
    "latin1_digit_id": (b"VERTEX_SE2 \xb2 0 0 0\n", "is not a node id"),
    "number_forms": (vertex("1.").replace("VERTEX_SE2 0 0 0 0", "VERTEX_SE2 0 .5 -0 1E1"), None),
    "exponent_forms": (vertex("1e+5").replace("VERTEX_SE2 0 0 0 0", "VERTEX_SE2 0 -2.5e-3 1e308 0"), None),
    "subnormal": (vertex("3e-324"), None),
    "zero_with_huge_exponent": (vertex("0.0e-999999"), None),
    "underflow_to_zero": (vertex("1e-400"), "field 2 of VERTEX_SE2 ('1e-400') is not finite"),
    "overflow": (vertex("1.7976931348623159e308"), "is not finite"),
    "plus_sign": (vertex("+1"), "field 2 of VERTEX_SE2 ('+1') is not a number"),
    "underscore": (vertex("1_0"), "is not a number"),
    "hex": (vertex("0x10"), "is not a number"),
    "exponent_without_digits": (vertex("1e"), "is not a number"),
    "lone_dot": (vertex("."), "is not a number"),
    "nan": (vertex("nan"), "is not finite"),
    "nan_payload": (vertex("nan(1)"), "is not finite"),
    "infinity": (vertex("-Infinity"), "is not finite"),
    "inf_prefix": (vertex("infin"), "is not a number"),
    "measurement_field_number": (V01 + "EDGE_SE2 0 1 1 x 0 1 0 0 1 0 1\n", "field 4 of EDGE_SE2 ('x')"),
    "information_field_number": (V01 + "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 y\n", "field 11 of EDGE_SE2 ('y')"),
    "duplicate_vertex": (BASE + "VERTEX_SE2 1 5 0 0\n", "duplicate vertex id 1 (first defined on line 2)"),
    "duplicate_vertex_with_a_bad_number": (BASE + "VERTEX_SE2 1 5 z 0\n", "('z') is not a number"),
    "self_loop": (V01 + "EDGE_SE2 1 1 1 0 0 1 0 0 1 0 1\n", "self-loop: edge from node 1 to itself"),
    "self_loop_before_a_bad_number": (V01 + "EDGE_SE2 1 1 x 0 0 1 0 0 1 0 1\n", "self-loop"),
    "unknown_node": (BASE + "EDGE_SE2 1 7 1 0 0 1 0 0 1 0 1\n", "edge refers to unknown node 7"),
    "vertex_field_count": ("VERTEX_SE2 0 0 0\n", "VERTEX_SE2 expects 4 fields after the tag, found 3"),
    "edge_field_count": (V01 + "EDGE2 0 1 1 0 0 1 0 0 1 0 1 1\n", "EDGE2 expects 11 fields after the tag, found 12"),
    "tag_alone": ("VERTEX2\n", "found 0"),
    "not_positive_definite": (V01 + "EDGE_SE2 0 1 1 0 0 1 2 0 1 0 1\n", "the matrix is not positive definite"),
    "semidefinite": (V01 + "EDGE_SE2 0 1 1 0 0 1 0 0 0 0 1\n", "the matrix is not positive definite"),
    # Positive definite in TORO's order (xx xy yy tt xt yt), not in g2o's.
    "toro_order_is_checked": (V01.replace("_SE2", "2") + "EDGE2 0 1 1 0 0 1 0 1 1 0.9 0\n", None),
    "g2o_order_is_checked": (V01 + "EDGE_SE2 0 1 1 0 0 1 0 1 1 0.9 0\n", "the matrix is not positive definite"),
    "empty": ("", "no vertices or edges in the file"),
    # Dense factors (core/dense_factor.h) over nodes 1 and 2, the only link of node 2.
    "dense_factor": (V01 + "VERTEX_SE2 2 2 0 0\n" + E01 + DENSE_12, None),
    "dense_factor_alone": ("VERTEX_SE2 0 0 0 0\nRRR_DENSE_SE2\n", "needs at least 1 fields after the tag, found 0"),
    "dense_factor_count": (BASE + "RRR_DENSE_SE2 1 0\n", "node count 1: a dense factor has 2 or more"),
    "dense_factor_fields": (BASE + "RRR_DENSE_SE2 2 0 1 1 0 0\n", "RRR_DENSE_SE2 expects 16 fields after the tag"),
    "dense_factor_twice": (BASE + DENSE_12.replace(" 1 2 ", " 1 1 "), "dense factor: node 1 is listed twice"),
    "dense_factor_not_positive_definite": (BASE + "VERTEX_SE2 2 2 0 0\n" + DENSE_12.replace(" 1 0 0 1 0 1 0", " 1 0 0 -1 0 1 0"),
                                           "dense factor: its information is not positive definite"),
    "dense_factor_unknown_node": (BASE + DENSE_12.replace(" 1 2 ", " 1 9 "), "dense factor refers to unknown node 9"),
    "only_comments": ("# nothing\n\n", "no vertices or edges in the file"),
}

COMPRESSION_CASES = {
    # name: (bytes, expected)
    "gzip.g2o.gz": (gzip.compress(BASE.encode(), mtime=0), None),
    "gzip_without_gz_name.g2o": (gzip.compress(BASE.encode(), mtime=0), None),
    "plain_with_gz_name.g2o.gz": (BASE.encode(), None),
    "two_members.g2o.gz": (gzip.compress(V01.encode(), mtime=0) + gzip.compress(E01.encode(), mtime=0), None),
    "trailing_garbage.g2o.gz": (gzip.compress(BASE.encode(), mtime=0) + b"not gzip", None),
    "magic_only.g2o": (b"\x1f\x8b", "read error"),
}


def many_vertices():
    return gzip.compress(b"".join(f"VERTEX_SE2 {i} {i} 0 0\n".encode() for i in range(3000)), mtime=0)


def corrupted():
    data = bytearray(many_vertices())
    data[len(data) // 2] ^= 0xFF
    return bytes(data)


COMPRESSION_CASES["truncated.g2o.gz"] = (many_vertices()[:-300], "read error")
COMPRESSION_CASES["corrupt.g2o.gz"] = (corrupted(), "read error")


def python_read(path):
    """('ok', nodes, edges) or ('error', message) from the Python reader."""
    try:
        graph = read_graph(path, allow_disconnected=False)
    except GraphFileError as e:
        return "error", str(e)
    edges = [(e.source, e.target, e.measurement, e.information) for e in graph.edges]
    edges += [(f.nodes, f.measurements, f.mean, f.information, f.offset) for f in graph.dense_factors]
    return "ok", graph.poses, edges


def parse_g2o(path):
    """The g2o file rrr_optimize wrote: every line VERTEX_SE2 or EDGE_SE2, nothing else."""
    poses, edges = {}, []
    with open(path) as f:
        for line in f:
            tag, *v = line.split()
            if tag == "VERTEX_SE2":
                poses[int(v[0])] = tuple(float(x) for x in v[1:])
            elif tag == "RRR_DENSE_SE2":
                n = int(v[0])
                numbers = [float(x) for x in v[1 + n:]]
                rows = 3 * (n - 1)
                edges.append(([int(x) for x in v[1:1 + n]],
                              [tuple(numbers[3 * a:3 * a + 3]) for a in range(n - 1)],
                              numbers[rows:2 * rows], numbers[2 * rows:-1], numbers[-1]))
            else:
                assert tag == "EDGE_SE2", line
                numbers = [float(x) for x in v[2:]]
                edges.append((int(v[0]), int(v[1]), tuple(numbers[:3]), tuple(numbers[3:])))
    return poses, edges


def cxx_read(path, folder):
    """('ok', nodes, edges) or ('error', message) from the C++ reader (through rrr_optimize)."""
    out = os.path.join(str(folder), "cxx_read_back.g2o")
    result = subprocess.run([OPTIMIZE, path, "--output", out, "--max-iterations", "0", "--init", "file"],
                            capture_output=True)
    if result.returncode != 0:
        stderr = result.stderr.decode("latin-1").strip()
        assert stderr.startswith("rrr_optimize: "), stderr
        return "error", stderr[len("rrr_optimize: "):].splitlines()[0]
    poses, edges = parse_g2o(out)
    os.unlink(out)
    return "ok", poses, edges


def same_angle(a, b):
    """Equal angles: both sides wrap into (-pi, pi] (core::normalizeAngle, graph_io.py)."""
    return close(a, b)


def close(a, b):
    return math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-12)


def comparable(message):
    """What both messages must share: the eigenvalues are printed differently, and zlib words
    its read errors itself (and, reading ahead in blocks, names an earlier line)."""
    message = message.split(" (eigenvalues")[0]
    if ": read error: " in message:
        return message.split(":")[0] + ": read error"
    return message


def assert_agree(cxx, python):
    def outcome(result):
        return result[1] if result[0] == "error" else "read"

    assert cxx[0] == python[0], f"C++: {outcome(cxx)}; Python: {outcome(python)}"
    if cxx[0] == "error":
        assert comparable(python[1]) == comparable(cxx[1])
        return
    (_, cxx_poses, cxx_edges), (_, py_poses, py_edges) = cxx, python
    assert sorted(cxx_poses) == sorted(py_poses)
    for i, (x, y, t) in py_poses.items():
        cx, cy, ct = cxx_poses[i]
        assert close(x, cx) and close(y, cy) and same_angle(t, ct), (i, (x, y, t), cxx_poses[i])
    assert len(cxx_edges) == len(py_edges)
    dense = [(p, c) for p, c in zip(py_edges, cxx_edges) if len(p) == 5]
    for p, c in dense:  # a dense factor: nodes, measurements, mean, information, offset
        assert p[0] == c[0] and all(close(u, v) for u, v in zip(sum(map(list, p[1]), []), sum(map(list, c[1]), [])))
        assert all(close(u, v) for u, v in zip(list(p[2]) + list(p[3]) + [p[4]], list(c[2]) + list(c[3]) + [c[4]]))
    py_edges, cxx_edges = py_edges[:len(py_edges) - len(dense)], cxx_edges[:len(cxx_edges) - len(dense)]
    for k, ((a, b, z, info), (ca, cb, cz, cinfo)) in enumerate(zip(py_edges, cxx_edges)):
        assert (a, b) == (ca, cb), k
        assert close(z[0], cz[0]) and close(z[1], cz[1]) and same_angle(z[2], cz[2]), (k, z, cz)
        assert all(close(u, v) for u, v in zip(info, cinfo)), (k, info, cinfo)


def check_expected(python, expected):
    if expected is None:
        assert python[0] == "ok", python
    else:
        assert python[0] == "error" and expected in python[1], python


def write(folder, name, content):
    path = folder / name
    path.write_bytes(content.encode() if isinstance(content, str) else content)
    return str(path)


@pytest.mark.parametrize("name", sorted(EDGE_CASES))
def test_edge_case_python(tmp_path, name):
    content, expected = EDGE_CASES[name]
    check_expected(python_read(write(tmp_path, name + ".g2o", content)), expected)


@pytest.mark.parametrize("name", sorted(COMPRESSION_CASES))
def test_compression_case_python(tmp_path, name):
    content, expected = COMPRESSION_CASES[name]
    check_expected(python_read(write(tmp_path, name, content)), expected)


@needs_optimize
@pytest.mark.parametrize("name", sorted(EDGE_CASES))
def test_edge_case_agrees(tmp_path, name):
    path = write(tmp_path, name + ".g2o", EDGE_CASES[name][0])
    assert_agree(cxx_read(path, tmp_path), python_read(path))


@needs_optimize
@pytest.mark.parametrize("name", sorted(COMPRESSION_CASES))
def test_compression_case_agrees(tmp_path, name):
    path = write(tmp_path, name, COMPRESSION_CASES[name][0])
    assert_agree(cxx_read(path, tmp_path), python_read(path))


@needs_optimize
@pytest.mark.parametrize("path", BUNDLED, ids=lambda p: os.path.relpath(p, DATA))
def test_bundled_graph_agrees(tmp_path, path):
    python = python_read(path)
    assert python[0] == "ok", python  # every bundled graph is connected and well formed
    assert_agree(cxx_read(path, tmp_path), python)


def test_every_bundled_graph_is_covered():
    names = {os.path.relpath(p, DATA) for p in BUNDLED}
    assert {"csail.toro.gz", "FR079_P_toro.graph.gz", "intel.g2o.gz", "kitti/kitti_00_GT.g2o.gz",
            "b25b/B25b_0.000.g2o.gz"} <= names
    assert len(names) >= 39


def test_the_comparison_notices_a_difference(tmp_path):
    """The checks themselves: a changed pose, measurement, information entry, edge order or
    message fails them, and so does -pi for pi (both readers wrap into (-pi, pi])."""
    path = write(tmp_path, "g.g2o", EDGE_CASES["toro"][0])
    good = python_read(path)
    _, poses, edges = good
    assert_agree(good, good)
    with pytest.raises(AssertionError):
        assert_agree(("ok", {**poses, 2: (2.0, 0.0, -math.pi)}, edges), ("ok", {**poses, 2: (2.0, 0.0, math.pi)}, edges))
    a, b, z, info = edges[1]
    for changed in (("ok", {**poses, 1: (1.0 + 1e-9, 0.0, 0.0)}, edges),
                    ("ok", poses, edges[:1] + [(a, b, (z[0], z[1], z[2] + 1e-9), info)] + edges[2:]),
                    ("ok", poses, edges[:1] + [(a, b, z, info[:5] + (info[5] * (1 + 1e-9),))] + edges[2:]),
                    ("ok", poses, edges[::-1]),
                    ("error", "g.g2o:2: something")):
        with pytest.raises(AssertionError):
            assert_agree(changed, good)


@needs_optimize
def test_nul_byte(tmp_path):
    # A NUL is an error naming the line (it could hide a loop candidate after a comment).
    path = write(tmp_path, "nul.g2o", b"VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\x00 junk\n" + E01.encode())
    result = python_read(path)
    assert result[0] == "error" and ":2: NUL byte at column 19" in result[1], result
    assert_agree(cxx_read(path, tmp_path), result)
    comment = write(tmp_path, "nul_comment.g2o",
                    b"# note\x00\nVERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n" + E01.encode())
    assert python_read(comment)[0] == "error"
    assert_agree(cxx_read(comment, tmp_path), python_read(comment))
