#!/usr/bin/python3
"""rostest for the nodelet and the standalone node (the .test files choose which one runs):
a lockstep replay of a bundled graph with injected outliers, then tf, markers, ~save / rrr_offline,
~load and malformed messages. Thresholds are parameters of the .test file."""
import math
import os
import subprocess
import sys
import tempfile
import time
import unittest

import roslib.packages
import rospy
import rostest
from std_srvs.srv import Trigger
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from rrr_graphslam.decision_stream import candidate_histories  # noqa: E402
from rrr_graphslam.evaluation import read_decisions, score  # noqa: E402
from rrr_graphslam.graph_io import read_graph  # noqa: E402
from rrr_graphslam.msg import LoopCandidate, PoseGraphEdge  # noqa: E402
from rrr_graphslam.outliers import add_outliers  # noqa: E402
from rrr_graphslam.replay import decisions_in_file_order, file_index_by_arrival  # noqa: E402
from rrr_graphslam.replay_ros import PoseGraphReplay  # noqa: E402
from rrr_graphslam.srv import LoadGraph, SaveGraph  # noqa: E402
from rostest_helpers import wait_for  # noqa: E402


NODE = "/rrr_graphslam"


class RrrGraphSlamRos(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("rrr_graphslam_test")
        cls.tf = []
        cls.markers = None
        rospy.Subscriber("/tf", TFMessage, lambda m: cls.tf.extend(m.transforms), queue_size=1000)
        rospy.Subscriber(NODE + "/markers", MarkerArray, cls._on_markers, queue_size=10)
        data = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data")
        graph = read_graph(os.path.join(data, rospy.get_param("~graph", "intel.g2o.gz")))
        cls.graph, cls.labels = add_outliers(graph, rospy.get_param("~outlier_kind", "random"),
                                             rospy.get_param("~outliers", 50), rospy.get_param("~seed", 1))
        cls.replay = PoseGraphReplay(NODE, timeout=60.0)
        cls.replay.connect(reset=True)
        cls.plan = cls.replay.run(cls.graph, rate=100.0, lockstep=True, finish=True)
        cls.rows = decisions_in_file_order(cls.plan, cls.replay.final_by_pair())

    @classmethod
    def _on_markers(cls, msg):
        cls.markers = msg

    def status(self):
        return self.replay.status

    def test_1_rejects_every_outlier_and_keeps_true_loops(self):
        decisions = self.rows
        # Every decided candidate says which step of RRR (or which verifier) decided it.
        self.assertFalse([d for d in decisions if d.verdict != "pending" and not d.reason])
        verifier = rospy.get_param(NODE + "/verifier", "rrr")
        self.assertEqual(self.status().verifier, verifier)
        if verifier != "rrr":
            # (a duplicate in the file reports the decision of the candidate it duplicates)
            self.assertFalse([d for d in decisions
                              if not d.reason.split("(not sent): ")[-1].startswith(verifier)])
        truth = [label == 1 for _, _, label in self.labels]
        s = score(decisions, truth)
        print(f"precision {s.precision:.4f} recall {s.recall:.4f} (tp {s.tp} fp {s.fp} fn {s.fn})")
        self.assertLessEqual(s.fp, rospy.get_param("~max_false_positives", 0))
        self.assertGreaterEqual(s.recall, rospy.get_param("~min_recall", 0.95))
        self.assertEqual(self.status().pending, 0)
        self.assertEqual(self.status().nodes, len(self.graph.poses))
        # Pose-graph mode: every candidate came from outside the loop search.
        self.assertEqual(self.replay.sources, {"external"})
        # The ~decisions stream, candidate by candidate (replay_posegraph --history): each starts
        # at its arrival and ends in the verdict the node reports at the end.
        by_arrival = file_index_by_arrival(self.plan, self.replay.final_by_pair())
        histories = candidate_histories(self.replay.stream)
        self.assertEqual(set(histories), set(by_arrival))
        for arrival, history in histories.items():
            # Each arrives pending, changes in time order, and only to another verdict.
            self.assertEqual(history[0].verdict, "pending", history)
            self.assertTrue(all(a.nodes <= b.nodes and a.verdict != b.verdict
                                for a, b in zip(history, history[1:])), history)
            self.assertEqual(history[-1].verdict, by_arrival[arrival][1][1], history)

    def test_2_publishes_map_to_odom(self):
        self.assertTrue(wait_for(lambda: any(t.header.frame_id == "map" and t.child_frame_id == "odom"
                                             for t in list(self.tf))), "no map -> odom on /tf")
        t = [t for t in list(self.tf) if t.child_frame_id == "odom"][-1].transform
        self.assertAlmostEqual(t.rotation.x ** 2 + t.rotation.y ** 2 + t.rotation.z ** 2 + t.rotation.w ** 2, 1.0, 6)

    def test_3_markers_match_the_decisions(self):
        s = self.status()

        def counts():
            if self.markers is None:
                return None
            return {m.ns: len(m.points) for m in self.markers.markers}

        expected = {"loops_accepted": 2 * s.accepted, "loops_rejected": 2 * s.rejected,
                    "loops_pending": 2 * s.pending, "nodes": s.nodes}
        self.assertTrue(wait_for(lambda: counts() is not None and
                                 all(counts().get(k) == v for k, v in expected.items())),
                        f"markers {counts()} != {expected}")
        self.assertEqual(counts()["odometry"], 2 * (s.nodes - s.sessions))

    def test_4_save_is_read_back_by_rrr_offline_with_the_same_decisions(self):
        folder = tempfile.mkdtemp()
        path = os.path.join(folder, "saved.g2o")
        answer = rospy.ServiceProxy(NODE + "/save", SaveGraph)(path=path, decisions_path="", optimized_path=os.path.join(folder, "opt.g2o"))
        self.assertTrue(answer.success, answer.message)
        saved = read_decisions(os.path.join(folder, "saved.decisions.tsv"))
        self.assertEqual(len(saved), self.status().candidates)
        self.assertFalse([f for f in os.listdir(folder) if f.startswith(".") or "tmp" in f], "temp files left")
        offline = roslib.packages.find_node("rrr_graphslam", "rrr_offline")[0]
        out = os.path.join(folder, "offline.tsv")
        gap = rospy.get_param(NODE + "/cluster_gap", 10)
        verifier = rospy.get_param(NODE + "/verifier", "rrr")
        run = subprocess.run([offline, path, "--decisions", out, "--cluster-gap", str(gap),
                              "--verifier", verifier, "--quiet"], capture_output=True, text=True)
        self.assertEqual(run.returncode, 0, run.stderr)
        offline_rows = read_decisions(out)
        self.assertEqual([(d.source, d.target, d.verdict) for d in offline_rows],
                         [(d.source, d.target, d.verdict) for d in saved])
        # ~load gives back the same graph and decisions.
        answer = rospy.ServiceProxy(NODE + "/load", LoadGraph)(path=path)
        self.assertTrue(answer.success, answer.message)
        self.assertTrue(wait_for(lambda: self.status().nodes == len(self.graph.poses) and
                                 self.status().accepted == sum(d.verdict == "accepted" for d in saved)))
        bad = rospy.ServiceProxy(NODE + "/load", LoadGraph)(path=os.path.join(folder, "missing.g2o"))
        self.assertFalse(bad.success)
        self.assertIn("missing.g2o", bad.message)

    def test_5_malformed_messages_leave_the_node_alive(self):
        before = self.status().messages_malformed
        pub_c = rospy.Publisher("/loop_candidates", LoopCandidate, queue_size=10)
        pub_e = rospy.Publisher("/pose_graph_edges", PoseGraphEdge, queue_size=10)
        self.assertTrue(wait_for(lambda: pub_c.get_num_connections() > 0 and pub_e.get_num_connections() > 0))
        ident = [1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0]
        n = self.status().nodes
        bad = [
            (pub_c, LoopCandidate(from_id=5, to_id=300, information=ident)),               # fine: the control
            (pub_c, LoopCandidate(from_id=5, to_id=300, information=ident)),               # duplicate
            (pub_c, LoopCandidate(from_id=7, to_id=400, information=[1, 0, 0, 0, -1, 0, 0, 0, 1])),  # not PD
            (pub_c, LoopCandidate(from_id=7, to_id=400, information=[math.nan] + ident[1:])),  # NaN
            (pub_c, LoopCandidate(from_id=7, to_id=7, information=ident)),                 # self-loop
            (pub_e, PoseGraphEdge(from_id=3, to_id=4, information=ident)),                 # out of order
        ]
        for pub, msg in bad:
            pub.publish(msg)
            time.sleep(0.05)
        self.assertTrue(wait_for(lambda: self.status().messages_malformed == before + len(bad) - 1),
                        f"malformed {self.status().messages_malformed - before}, expected {len(bad) - 1}")
        answer = rospy.ServiceProxy(NODE + "/optimize", Trigger)()
        self.assertTrue(answer.success, answer.message)
        self.assertEqual(self.status().nodes, n)


if __name__ == "__main__":
    rostest.rosrun("rrr_graphslam", "rrr_graphslam_ros", RrrGraphSlamRos)
