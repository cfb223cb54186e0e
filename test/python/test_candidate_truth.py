"""candidate_truth: the front end's candidates labelled by a reference trajectory, and RRR's
precision and recall on them."""
import math

import pytest
from rrr_graphslam.candidate_truth import (REFERENCE_SIGMA, candidate_labels, node_references,
                                           reference_chi2, score_candidates, write_labels)
from rrr_graphslam.evaluation import read_decisions, read_truth
from rrr_graphslam.graph_io import Edge, between, compose

TIGHT = (1e4, 0.0, 0.0, 1e4, 0.0, 1e5)  # a scan matcher's information: 1 cm, 0.2 degrees


def loop(source, target, measurement, information=TIGHT):
    return Edge(source, target, measurement, information, 0)


def test_the_reference_noise_keeps_a_tight_true_candidate_true_and_a_far_one_false():
    reference = {0: (0.0, 0.0, 0.0), 1: (2.0, 1.0, 0.5)}
    truth = between(reference[0], reference[1])
    assert reference_chi2(loop(0, 1, truth), reference) == pytest.approx(0.0, abs=1e-12)
    # 4 cm and 0.5 degrees off: beyond the candidate's own 1 cm, within the reference's 5 cm.
    near = compose(truth, (0.04, 0.0, math.radians(0.5)))
    assert reference_chi2(loop(0, 1, near), reference) < 11.34
    assert reference_chi2(loop(0, 1, near), reference, sigma=(0.0, 0.0, 0.0)) > 11.34
    far = compose(truth, (0.5, 0.0, 0.0))
    assert reference_chi2(loop(0, 1, far), reference) > 11.34
    assert reference_chi2(loop(0, 2, truth), reference) is None
    assert reference_chi2(loop(0, 1, truth), {0: (0.0, 0.0, 0.0), 1: None}) is None


def test_score_counts_accepted_true_and_false_and_lists_the_false_accepted_worst_first():
    reference = {k: (float(k), 0.0, 0.0) for k in range(6)}
    true = lambda a, b: loop(a, b, between(reference[a], reference[b]))
    off = lambda a, b, m: loop(a, b, compose(between(reference[a], reference[b]), (m, 0.0, 0.0)))
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


def test_node_references_turn_the_laser_pose_of_each_nodes_scan_into_the_robots():
    class Truth:
        def pose(self, t):
            return None if t > 10 else (t, 0.0, math.pi / 2)

    to_robot = (-0.1, 0.0, 0.0)  # the laser 0.1 m ahead of the robot
    out = node_references([4, 7, 9], [1.0, 2.0, 11.0], Truth(), to_robot)
    assert out[4] == pytest.approx((1.0, -0.1, math.pi / 2))
    assert out[7] == pytest.approx((2.0, -0.1, math.pi / 2))
    assert out[9] is None
    with pytest.raises(ValueError, match="3 nodes but 2 node timestamps"):
        node_references([4, 7, 9], [1.0, 2.0], Truth(), to_robot)
    assert REFERENCE_SIGMA[0] > 0.0


def test_the_labels_file_scores_other_decisions_as_the_evaluation_reads_it(tmp_path):
    reference = {0: (0.0, 0.0, 0.0), 1: (1.0, 0.0, 0.0), 2: (2.0, 0.0, 0.0)}
    loops = [loop(0, 2, (2.0, 0.0, 0.0)), loop(0, 2, (2.5, 0.0, 0.0)), loop(1, 7, (1.0, 0.0, 0.0))]
    labels = candidate_labels(loops, reference)
    assert labels == [True, False, None]
    write_labels(str(tmp_path / "c.labels"), loops, labels)
    assert (tmp_path / "c.labels").read_text() == "0 2 1\n0 2 0\n1 7 -1\n"
    (tmp_path / "d.tsv").write_text("from\tto\tcluster\tverdict\n0\t2\t0\taccepted\n"
                                    "0\t2\t0\trejected\n1\t7\t1\taccepted\n")
    decisions = read_decisions(str(tmp_path / "d.tsv"))
    assert read_truth(str(tmp_path / "c.labels"), decisions) == [True, False, None]
