"""candidate_truth: the front end's candidates labelled by a reference trajectory, and RRR's
precision and recall on them."""
import math

import pytest
from rrr_graphslam.bench_sessions import GroundTruth, RawScan
from rrr_graphslam.candidate_truth import (MAX_BRIDGE_M, NodeReference, candidate_labels,
                                           node_references, reference_chi2, score_candidates,
                                           turn_drift, write_labels)
from rrr_graphslam.evaluation import read_decisions, read_truth
from rrr_graphslam.graph_io import Edge, between, compose

TIGHT = (1e4, 0.0, 0.0, 1e4, 0.0, 1e5)  # a scan matcher's information: 1 cm, 0.2 degrees


def loop(source, target, measurement, information=TIGHT):
    return Edge(source, target, measurement, information, 0)


def at(*poses, bridge=0.0):
    return {k: NodeReference(p, bridge) for k, p in enumerate(poses)}


def test_the_reference_noise_keeps_a_tight_true_candidate_true_and_a_far_one_false():
    reference = at((0.0, 0.0, 0.0), (2.0, 1.0, 0.5))
    truth = between(reference[0].pose, reference[1].pose)
    assert reference_chi2(loop(0, 1, truth), reference) == pytest.approx(0.0, abs=1e-12)
    # 4 cm and 0.5 degrees off: beyond the candidate's own 1 cm, within the reference's 5 cm.
    near = compose(truth, (0.04, 0.0, math.radians(0.5)))
    assert reference_chi2(loop(0, 1, near), reference) < 11.34
    assert reference_chi2(loop(0, 1, near), reference, sigma=(0.0, 0.0, 0.0)) > 11.34
    far = compose(truth, (0.5, 0.0, 0.0))
    assert reference_chi2(loop(0, 1, far), reference) > 11.34
    assert reference_chi2(loop(0, 2, truth), reference) is None
    assert reference_chi2(loop(0, 1, truth), {0: reference[0], 1: None}) is None


def test_a_bridge_widens_the_reference_and_a_long_one_leaves_the_candidate_unlabelled():
    poses = ((0.0, 0.0, 0.0), (2.0, 1.0, 0.5))
    truth = between(*poses)
    off = loop(0, 1, compose(truth, (0.15, 0.0, math.radians(2.5))))
    # 15 cm and 2.5 degrees off: false between two corrected scans.
    assert reference_chi2(off, at(*poses)) > 11.34
    assert reference_chi2(off, at(*poses, bridge=0.4)) < 11.34  # within 0.8 m of bridges: no call
    assert reference_chi2(off, at(*poses, bridge=MAX_BRIDGE_M + 0.01)) is None
    assert candidate_labels([off], at(*poses, bridge=1.0)) == [None]


def test_score_counts_accepted_true_and_false_and_lists_the_false_accepted_worst_first():
    reference = at(*[(float(k), 0.0, 0.0) for k in range(6)])
    true = lambda a, b: loop(a, b, between(reference[a].pose, reference[b].pose))
    off = lambda a, b, m: loop(a, b, compose(between(reference[a].pose, reference[b].pose),
                                             (m, 0.0, 0.0)))
    loops = [true(0, 3), true(1, 4), true(2, 5), off(0, 4, 0.8), off(1, 5, 1.5), off(2, 4, 0.7),
             loop(0, 9, (0.0, 0.0, 0.0))]
    verdicts = ["accepted", "accepted", "rejected", "accepted", "accepted", "rejected", "accepted"]
    s = score_candidates(loops, verdicts, reference)
    assert (s.candidates, s.true, s.false, s.unlabelled) == (7, 3, 3, 1)
    assert (s.accepted_true, s.accepted_false) == (2, 2)
    assert s.precision == pytest.approx(0.5) and s.recall == pytest.approx(2 / 3)
    assert [(f[0], f[1]) for f in s.false_accepted] == [(1, 5), (0, 4)]
    assert s.false_accepted[0][2] == pytest.approx(1.5)
    with pytest.raises(ValueError, match="7 loop candidates but 6 decisions"):
        score_candidates(loops, verdicts[:-1], reference)
    empty = score_candidates([], [], reference)
    assert empty.precision == 1.0 and empty.recall == 1.0


def test_node_references_place_each_nodes_scan_from_the_corrected_ones_and_measure_the_bridge():
    # Ten scans 0.2 m apart along x; the corrected log holds scans 0 and 9, 0.1 m to the left of
    # the odometry; the laser 0.1 m ahead of the robot.
    raw = [RawScan(100.0 + k, float(k), (0.2 * k, 0.0, 0.0), (float(k),)) for k in range(10)]
    corrected = [(0.0, (0.1, 0.1, 0.0), (0.0,)), (9.0, (1.9, 0.1, 0.0), (9.0,))]
    truth = GroundTruth(raw, corrected)
    to_robot = (-0.1, 0.0, 0.0)
    out = node_references([4, 7, 9, 11], [100.0, 102.0, 109.0, 250.0], truth, to_robot)
    assert out[4].pose == pytest.approx((0.0, 0.1, 0.0)) and out[4].bridge == 0.0
    assert out[7].pose == pytest.approx((0.4, 0.1, 0.0))
    assert out[7].bridge == pytest.approx(0.4)  # two scans from the first corrected one
    assert out[9].bridge == 0.0
    assert out[11] is None  # no scan at that time
    with pytest.raises(ValueError, match="3 nodes but 2 node timestamps"):
        node_references([4, 7, 9], [1.0, 2.0], truth, to_robot)


def test_the_labels_file_scores_other_decisions_as_the_evaluation_reads_it(tmp_path):
    reference = at((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (2.0, 0.0, 0.0))
    loops = [loop(0, 2, (2.0, 0.0, 0.0)), loop(0, 2, (2.5, 0.0, 0.0)), loop(1, 7, (1.0, 0.0, 0.0))]
    labels = candidate_labels(loops, reference)
    assert labels == [True, False, None]
    write_labels(str(tmp_path / "c.labels"), loops, labels)
    assert (tmp_path / "c.labels").read_text() == "0 2 1\n0 2 0\n1 7 -1\n"
    (tmp_path / "d.tsv").write_text("from\tto\tcluster\tverdict\n0\t2\t0\taccepted\n"
                                    "0\t2\t0\trejected\n1\t7\t1\taccepted\n")
    decisions = read_decisions(str(tmp_path / "d.tsv"))
    assert read_truth(str(tmp_path / "c.labels"), decisions) == [True, False, None]


def test_turn_drift_recovers_a_random_walks_step_deviation_and_stops_at_a_gap():
    import random
    rng = random.Random(3)
    sigma, n = 0.002, 3000
    truth, odometry, heading = {}, [], 0.0
    for k in range(n):
        truth[k] = NodeReference((0.0, 0.0, math.remainder(heading, 2 * math.pi)),
                                 0.0 if k % 7 == 0 else 0.3)  # every 7th node at a corrected scan
        turn = 0.05 * math.sin(k / 40.0)
        heading += turn
        odometry.append(Edge(k, k + 1, (0.1, 0.0, turn + rng.gauss(0.0, sigma)), TIGHT, 0))
    drift = turn_drift(odometry, truth)
    assert drift.per_step_rad == pytest.approx(sigma, rel=0.15)
    assert drift.pairs > 1000
    # A loop between consecutive ids listed after the odometry is not a step.
    with_loop = odometry + [Edge(10, 11, (0.0, 0.0, 1.0), TIGHT, 0)]
    assert turn_drift(with_loop, truth).per_step_rad == drift.per_step_rad
    # Exact steps: no drift. Without the step 1499 -> 1500 the chain breaks: pairs only on one side.
    exact = [Edge(e.source, e.target, (0.1, 0.0, 0.05 * math.sin(e.source / 40.0)), TIGHT, 0)
             for e in odometry]
    assert turn_drift(exact, truth).per_step_rad == pytest.approx(0.0, abs=1e-9)
    gap = [e for e in odometry if e.source != 1499]
    assert turn_drift(gap, truth).pairs < drift.pairs
    assert turn_drift(odometry, truth, min_steps=5000) is None
