"""Replay ordering and the mapping of the node's answers back to the file (no ROS master)."""
import math
import os
import random

import numpy as np
from conftest import DATA
from rrr_graphslam.graph_io import Edge, PoseGraph, between, compose, read_graph
from rrr_graphslam.evaluation import Decision, read_decisions, write_decisions
from rrr_graphslam.replay import (decisions_in_file_order, file_index_by_arrival, information_row_major,
                                  inverted_edge, plan_replay)


def chi2(edge_measurement, info9, xi, xj):
    e = np.array(between(edge_measurement, between(xi, xj)))
    return float(e @ np.reshape(info9, (3, 3)) @ e)


def test_information_row_major_mirrors_the_upper_triangle():
    assert information_row_major((1, 2, 3, 4, 5, 6)) == [1.0, 2.0, 3.0, 2.0, 4.0, 5.0, 3.0, 5.0, 6.0]


def test_inverted_edge_has_the_same_chi2_at_any_poses():
    rng = random.Random(4)
    for _ in range(50):
        z = (rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-3, 3))
        upper = (40.0, 3.0, -2.0, 25.0, 1.0, 90.0)
        edge = Edge(7, 3, z, upper)
        z_inv, info_inv = inverted_edge(edge)
        xi = (rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-3, 3))
        # Near the measurement (first order): poses with xj = xi * z * small noise.
        xj = compose(compose(xi, z), (rng.gauss(0, 1e-4), rng.gauss(0, 1e-4), rng.gauss(0, 1e-4)))
        a = chi2(z, information_row_major(upper), xi, xj)
        b = chi2(z_inv, info_inv, xj, xi)
        assert math.isclose(a, b, rel_tol=1e-3, abs_tol=1e-12)


def graph_with(edges, n):
    g = PoseGraph()
    for k in range(n):
        g.poses[k] = (float(k), 0.0, 0.0)
    g.edges = [Edge(a, b, z, (1, 0, 0, 1, 0, 1)) for a, b, z in edges]
    return g


def test_plan_sends_nodes_in_order_with_candidates_at_their_newer_end():
    g = graph_with([(0, 1, (1, 0, 0)), (2, 1, (-1, 0, 0)), (2, 3, (1, 0, 0)), (3, 0, (-3, 0, 0)),
                    (0, 2, (2, 0, 0)), (0, 2, (2, 0, 0))], 4)
    plan = plan_replay(g)
    assert [s.node for s in plan.steps] == [0, 1, 2, 3]
    assert plan.steps[0].odometry is None
    assert (plan.steps[2].odometry.source, plan.steps[2].odometry.target) == (1, 2)
    assert plan.steps[2].odometry.measurement[0] == 1.0  # 2 -> 1 inverted
    assert [c.index for c in plan.steps[2].candidates] == [1, 2]
    assert [c.index for c in plan.steps[3].candidates] == [0]
    assert plan.candidates[2].duplicate_of == 1


def test_a_node_without_odometry_starts_a_session():
    g = graph_with([(0, 1, (1, 0, 0)), (2, 3, (1, 0, 0)), (3, 0, (0, 0, 0))], 4)
    plan = plan_replay(g)
    assert plan.steps[2].odometry is None and plan.steps[3].odometry.source == 2


def test_answers_map_back_to_file_order_and_duplicates_share_the_verdict():
    g = graph_with([(0, 1, (1, 0, 0)), (1, 2, (1, 0, 0)), (2, 3, (1, 0, 0)), (3, 0, (-3, 0, 0)),
                    (2, 0, (2, 0, 0)), (3, 0, (-2.9, 0, 0)), (2, 0, (2, 0, 0))], 4)
    plan = plan_replay(g)
    # Arrival order: (2,0) first, then the two (3,0) ones; the duplicate (2,0) is never answered.
    final = {(2, 0): [(0, "accepted", 4, "realize: a")],
             (3, 0): [(1, "rejected", 5, "intra: b"), (2, "accepted", 5, "realize: c")]}
    rows = decisions_in_file_order(plan, final)
    assert [(d.source, d.target, d.cluster, d.verdict, d.reason) for d in rows] == [
        (3, 0, 5, "rejected", "intra: b"), (2, 0, 4, "accepted", "realize: a"),
        (3, 0, 5, "accepted", "realize: c"),
        (2, 0, 4, "accepted", "duplicate of file candidate 1 (not sent): realize: a")]
    pending = decisions_in_file_order(plan, {})[0]
    assert (pending.cluster, pending.verdict, pending.reason) == (-1, "pending", "no decision received from the node")
    # The node's arrival index -> the file's candidate (the ~decisions stream is by arrival index).
    assert {a: index for a, (index, _) in file_index_by_arrival(plan, final).items()} == {0: 1, 1: 0, 2: 2}


def test_decisions_written_with_reasons_read_back(tmp_path):
    rows = [Decision(3, 0, 5, "rejected", "intra: D2 12.1 >= 7.81"), Decision(2, 0, -1, "pending", "")]
    path = tmp_path / "d.tsv"
    write_decisions(str(path), rows)
    assert path.read_text().startswith("from\tto\tcluster\tverdict\treason\n")
    assert read_decisions(str(path)) == rows


def test_bundled_graph_plans_every_candidate():
    g = read_graph(os.path.join(DATA, "intel.g2o.gz"))
    plan = plan_replay(g)
    assert len(plan.candidates) == len(g.loops())
    assert sum(len(s.candidates) for s in plan.steps) == len(plan.candidates)
    assert all(s.odometry is not None for s in plan.steps[1:])
