"""The Python pose-graph reader and writer: same graphs as the C++ one, and the same errors."""
import math
import os

import pytest
from conftest import DATA
from rrr_graphslam.graph_io import GraphFileError, between, compose, read_graph, write_graph


def test_csail_g2o_and_toro_are_the_same_graph():
    g2o = read_graph(os.path.join(DATA, "csail.g2o.gz"))
    toro = read_graph(os.path.join(DATA, "csail.toro.gz"))
    assert len(g2o.poses) == 1045 and len(g2o.edges) == 1172
    assert g2o.poses == toro.poses
    for a, b in zip(g2o.edges, toro.edges):
        assert (a.source, a.target) == (b.source, b.target)
        assert a.measurement == pytest.approx(b.measurement, abs=1e-12)
        assert a.information == pytest.approx(b.information, rel=1e-12)
    assert g2o.edges[0].information[1] != 0.0  # xy: a swapped order would show


@pytest.mark.parametrize("name", ["out.g2o", "out.toro", "out.g2o.gz"])
def test_round_trip_is_exact(tmp_path, name):
    graph = read_graph(os.path.join(DATA, "ring.g2o.gz"))
    path = str(tmp_path / name)
    write_graph(graph, path)
    again = read_graph(path)
    assert again.poses == graph.poses
    assert [(e.source, e.target, e.measurement, e.information) for e in again.edges] == [
        (e.source, e.target, e.measurement, e.information) for e in graph.edges]
    assert os.listdir(tmp_path) == [name]  # atomic write leaves no temporary file


def test_edge_only_file_is_placed_by_odometry(tmp_path):
    path = tmp_path / "edges.g2o"
    path.write_text("EDGE_SE2 0 3 9 9 0 1 0 0 1 0 1\n" +
                    "".join(f"EDGE_SE2 {i} {i + 1} 1 0 0 1 0 0 1 0 1\n" for i in range(4)))
    graph = read_graph(str(path))
    for i in range(5):
        assert graph.poses[i] == pytest.approx((float(i), 0.0, 0.0))


@pytest.mark.parametrize("content,line,message", [
    ("VERTEX_SE2 0 0 0\n", 1, "expects 4 fields"),
    ("VERTEX_SE2 0 0 x 0\n", 1, "is not a number"),
    ("VERTEX_SE2 0 0 nan 0\n", 1, "not finite"),
    ("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 0 1 0 0\n", 2, "duplicate vertex id 0"),
    ("VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 2 0 1 0 1\n", 3, "not positive definite"),
    ("VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 0 1 0 0 1 0 0 1 0 1\n", 2, "self-loop"),
    ("VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 5 1 0 0 1 0 0 1 0 1\n", 2, "unknown node 5"),
    ("FOO 1 2\n", 1, "unknown tag"),
])
def test_bad_input_names_file_and_line(tmp_path, content, line, message):
    path = tmp_path / "bad.g2o"
    path.write_text(content)
    with pytest.raises(GraphFileError) as error:
        read_graph(str(path))
    assert error.value.line == line
    assert message in str(error.value)
    assert str(error.value).startswith(f"{path}:{line}:")


def test_se2_helpers():
    a, b = (1.0, 2.0, 0.5), (-0.3, 0.7, 3.0)
    assert between(a, compose(a, b)) == pytest.approx((b[0], b[1], b[2] - 2 * math.pi if b[2] > math.pi else b[2]))


def test_vertex_angles_are_normalized_like_measurements(tmp_path):
    path = tmp_path / "angles.g2o"
    path.write_text("VERTEX_SE2 0 0 0 4.0\nVERTEX_SE2 1 1 0 -3.141592653589793\n"
                    "EDGE_SE2 0 1 1 0 7.0 1 0 0 1 0 1\n")
    graph = read_graph(str(path))
    assert graph.poses[0][2] == pytest.approx(4.0 - 2 * math.pi, abs=1e-15)
    assert graph.poses[1][2] == math.pi
    assert graph.edges[0].measurement[2] == pytest.approx(7.0 - 2 * math.pi, abs=1e-15)


def test_disconnected_graph_names_its_components(tmp_path):
    path = tmp_path / "two.g2o"
    path.write_text("EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nEDGE_SE2 5 6 1 0 0 1 0 0 1 0 1\n")
    assert len(read_graph(str(path)).poses) == 4
    with pytest.raises(GraphFileError, match=r"two.g2o: graph is disconnected: 2 components: "
                                             r"\{0..1\} \(2 nodes\), \{5..6\} \(2 nodes\)"):
        read_graph(str(path), allow_disconnected=False)
