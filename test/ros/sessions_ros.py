#!/usr/bin/python3
"""rostest: ~save_map, ~load_map and a new session from another odometry frame, tied to the map."""
import gzip
import os
import re
import subprocess
import sys
import tempfile
import time
import unittest

import roslib.packages
import rospy
import rostest
from geometry_msgs.msg import PoseWithCovarianceStamped
from visualization_msgs.msg import MarkerArray

from rrr_graphslam.carmen import write_moved_log, write_there_and_back_log  # noqa: E402
from rrr_graphslam.msg import LoopClosureDecision, RrrStatus  # noqa: E402
from rrr_graphslam.srv import LoadMap, SaveMap  # noqa: E402
from rostest_helpers import wait_for  # noqa: E402


NODE = "/rrr_graphslam"


class Sessions(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("sessions_test")
        cls.status, cls.decisions = None, []
        rospy.Subscriber(NODE + "/status", RrrStatus, lambda m: setattr(cls, "status", m), queue_size=10)
        rospy.Subscriber(NODE + "/decisions", LoopClosureDecision, cls.decisions.append, queue_size=1000)
        rospy.wait_for_service(NODE + "/save_map", timeout=30.0)
        cls.save_map = rospy.ServiceProxy(NODE + "/save_map", SaveMap)
        cls.load_map = rospy.ServiceProxy(NODE + "/load_map", LoadMap)
        wait_for(lambda: cls.status is not None, 30.0)
        here = os.path.dirname(os.path.abspath(__file__))
        cls.log = os.path.join(here, "..", "data", rospy.get_param("~log"))
        cls.replay = os.path.join(here, "..", "..", "scripts", "replay_carmen")
        cls.folder = tempfile.mkdtemp()

    def play(self, log, name):
        env = dict(os.environ, PATH="/usr/bin:" + os.environ.get("PATH", ""))
        result = subprocess.run([sys.executable, self.replay, log, "--rate", str(rospy.get_param("~rate", 3.0)),
                                 f"__name:={name}"], env=env, capture_output=True, text=True, timeout=150)
        self.assertEqual(result.returncode, 0, result.stdout + result.stderr)
        self.assertTrue(wait_for(lambda: self.status.backlog == 0 and
                                 self.status.messages_processed == self.status.messages_received, 60.0))

    def save_map_of(self, name, filename):
        """Has node `name` save its map into the test's folder."""
        answer = rospy.ServiceProxy(f"/{name}/save_map", SaveMap)(path=os.path.join(self.folder, filename))
        self.assertTrue(answer.success, answer.message)

    def start_node(self, name, params):
        """Another rrr_graphslam_node named `name` with `params`: (process, dict whose 'last' is
        its newest ~status)."""
        for key, value in params.items():
            rospy.set_param(f"/{name}/{key}", value)
        status = {}
        rospy.Subscriber(f"/{name}/status", RrrStatus, lambda m: status.update(last=m), queue_size=10)
        binary = roslib.packages.find_node("rrr_graphslam", "rrr_graphslam_node")[0]
        env = dict(os.environ, ROSCONSOLE_STDOUT_LINE_BUFFERED="1")
        node = subprocess.Popen([binary, f"__name:={name}"], env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True)
        return node, status

    def test_a_saved_map_is_continued_by_a_session_from_another_frame(self):
        self.play(self.log, "replay_first")
        first_nodes = self.status.nodes
        self.assertGreater(first_nodes, 30)
        self.assertEqual(self.status.session, 0)
        path = os.path.join(self.folder, "map.rrrmap")
        answer = self.save_map(path=path)
        self.assertTrue(answer.success, answer.message)
        self.assertFalse([f for f in os.listdir(self.folder) if "tmp" in f], "temporary files left")

        # A damaged file is refused and the running map stays.
        bad = os.path.join(self.folder, "bad.rrrmap")
        with open(path, "rb") as f, open(bad, "wb") as g:
            g.write(f.read()[:100])
        answer = self.load_map(path=bad)
        self.assertFalse(answer.success)
        self.assertIn(bad, answer.message)
        self.assertTrue(wait_for(lambda: self.status.nodes == first_nodes, 5.0))

        answer = self.load_map(path=path)
        self.assertTrue(answer.success, answer.message)
        self.assertTrue(wait_for(lambda: self.status.session == 1 and self.status.nodes == first_nodes, 10.0),
                        str(self.status))
        self.assertFalse(self.status.tied_to_map)

        moved = os.path.join(self.folder, "moved.clf")
        write_moved_log(self.log, moved, (50.0, 20.0, 2.5), later=100.0)
        decisions_before = len(self.decisions)
        self.play(moved, "replay_second")
        self.assertGreater(self.status.nodes, first_nodes + 30)
        self.assertTrue(wait_for(lambda: self.status.tied_to_map, 10.0), str(self.status))
        self.assertGreaterEqual(self.status.tied_after_sec, 0.0)
        final = {}
        for d in self.decisions[decisions_before:]:
            final[d.candidate] = d
        crossing = [d for d in final.values() if (d.from_id < first_nodes) != (d.to_id < first_nodes)
                    and d.verdict == LoopClosureDecision.ACCEPTED]
        self.assertTrue(crossing, "no accepted loop between the sessions was published")
        # The session was placed by relocalization: whole-map searches, then searches around it.
        sources = {d.source for d in crossing}
        self.assertTrue(sources <= {"local-search", "whole-map-search", "rival-search"}, sources)

        # /initialpose (rviz's 2D Pose Estimate) must be in the map frame; either way the node goes on.
        publisher = rospy.Publisher("/initialpose", PoseWithCovarianceStamped, queue_size=1, latch=True)
        self.assertTrue(wait_for(lambda: publisher.get_num_connections() > 0, 10.0))
        malformed = self.status.messages_malformed
        wrong = PoseWithCovarianceStamped()
        wrong.header.frame_id = "odom"
        wrong.pose.pose.orientation.w = 1.0
        publisher.publish(wrong)
        self.assertTrue(wait_for(lambda: self.status.messages_malformed == malformed + 1, 10.0), str(self.status))
        Sessions.map_path = path

    def test_b_localization_tracks_the_robot_and_leaves_the_map_as_it_is(self):
        # A second node localizes in the map saved above: mode localization, map_file at start.
        name = "localizer"
        node, status = self.start_node(name, {
            "input_mode": "scan", "map_file": self.map_path, "mode": "localization",
            "publish_tf": False, "scans_per_submap": 10, "min_node_separation": 15,
            "relocalization_confirm_distance": 2.0})
        try:
            self.assertTrue(wait_for(lambda: "last" in status, 30.0), "the localizer did not start")
            loaded_nodes = status["last"].nodes
            self.assertEqual(status["last"].session, 1)
            moved = os.path.join(self.folder, "moved_again.clf")
            write_moved_log(self.log, moved, (-30.0, 70.0, -1.0), later=300.0)
            self.play(moved, "replay_third")
            self.assertTrue(wait_for(lambda: status["last"].tied_to_map, 10.0), str(status["last"]))
            self.assertGreater(status["last"].nodes, loaded_nodes)
            save = rospy.ServiceProxy(f"/{name}/save_map", SaveMap)
            answer = save(path=os.path.join(self.folder, "localized.rrrmap"))
            self.assertFalse(answer.success)
            self.assertIn("localization", answer.message)
        finally:
            node.terminate()
            node.wait(timeout=30)

    def test_c_lifelong_trims_the_map_it_saves(self):
        # A third node loads the first session's map with lifelong on: ~save_map trims the
        # submaps that later ones cover (keep_current_session false: the map's newest session,
        # here its only one, is judged too); loading the file back shows what it removed.
        name = "lifelong"
        node, status = self.start_node(name, {
            "input_mode": "scan", "map_file": self.map_path, "publish_tf": False,
            "scans_per_submap": 10, "min_node_separation": 15, "lifelong": True,
            "trim_overlap_ratio": 0.5, "keep_recent_submaps": 2, "keep_current_session": False})
        markers = {}
        rospy.Subscriber(f"/{name}/markers", MarkerArray,
                         lambda m: markers.update({k.ns: k for k in m.markers}), queue_size=10)
        try:
            self.assertTrue(wait_for(lambda: "last" in status, 30.0), "the lifelong node did not start")
            self.assertTrue(status["last"].lifelong)
            self.assertEqual(status["last"].trimmed_submaps, 0)
            rospy.wait_for_service(f"/{name}/save_map", timeout=30.0)
            trimmed = os.path.join(self.folder, "trimmed.rrrmap")
            answer = rospy.ServiceProxy(f"/{name}/save_map", SaveMap)(path=trimmed)
            self.assertTrue(answer.success, answer.message)
            submaps = int(re.search(r"lifelong: trimmed (\d+) submaps", answer.message).group(1))
            self.assertGreater(submaps, 0, answer.message)
            answer = rospy.ServiceProxy(f"/{name}/load_map", LoadMap)(path=trimmed)
            self.assertTrue(answer.success, answer.message)
            self.assertTrue(wait_for(lambda: status["last"].trimmed_submaps == submaps, 10.0), str(status["last"]))
            self.assertGreater(status["last"].marginalized_nodes, 0)
            self.assertGreater(status["last"].marginal_edges, 0)
            # What the trimmed submaps alone saw stays in the map (doc/lifelong.md, step 5).
            self.assertGreater(status["last"].remembered_cells, 0)
            self.assertTrue(wait_for(lambda: "marginal" in markers and markers["marginal"].points, 10.0),
                            sorted(markers))
        finally:
            node.terminate()
            node.wait(timeout=30)

    def test_d_scans_of_another_sensor_are_refused_once_and_flagged(self):
        # The map's scans have 180 beams 1 degree apart; every other beam is another sensor setup:
        # each such scan is dropped (counted malformed), the error is logged once, ~status says so.
        answer = self.load_map(path=self.map_path)
        self.assertTrue(answer.success, answer.message)
        self.assertTrue(wait_for(lambda: not self.status.sensor_mismatch, 10.0))
        thinned = os.path.join(self.folder, "thinned.clf")
        with gzip.open(self.log, "rt") as src, open(thinned, "w") as out:
            for line in src:
                fields = line.split()
                if fields and fields[0] == "FLASER":
                    n = int(fields[1])
                    ranges = fields[2:2 + n][::2]
                    line = " ".join(["FLASER", str(len(ranges))] + ranges + fields[2 + n:]) + "\n"
                out.write(line)
        malformed = self.status.messages_malformed
        self.play(thinned, "replay_thinned")
        self.assertTrue(wait_for(lambda: self.status.sensor_mismatch, 10.0), str(self.status))
        self.assertGreater(self.status.messages_malformed - malformed, 100)
        # A new map (here the same file again) checks the scans' setup anew.
        answer = self.load_map(path=self.map_path)
        self.assertTrue(answer.success, answer.message)
        self.assertTrue(wait_for(lambda: not self.status.sensor_mismatch, 10.0), str(self.status))

    def test_e_lifelong_trims_the_earlier_session_while_mapping(self):
        # A node continues the first session's map with trim_every_n_nodes: once the new session
        # (the same minute from another odometry frame) is tied, the first session's covered
        # submaps go while it maps, off the mapping thread, and the node goes on with the
        # trimmed map.
        node, status = self.start_node("online_trim", {
            "input_mode": "scan", "map_file": self.map_path, "publish_tf": False,
            "scans_per_submap": 10, "min_node_separation": 15,
            "relocalization_confirm_distance": 2.0, "lifelong": True, "trim_overlap_ratio": 0.5,
            "keep_recent_submaps": 2, "trim_every_n_nodes": 10})
        try:
            self.assertTrue(wait_for(lambda: "last" in status, 30.0), "the node did not start")
            loaded = status["last"].nodes
            self.assertEqual(status["last"].online_trims, 0)
            moved = os.path.join(self.folder, "moved_online.clf")
            write_moved_log(self.log, moved, (-20.0, 40.0, 1.5), later=500.0)
            self.play(moved, "replay_online")
            self.assertTrue(wait_for(lambda: status["last"].online_trims > 0 and
                                     status["last"].trimmed_submaps > 0, 20.0), str(status["last"]))
            last = status["last"]
            self.assertTrue(last.tied_to_map, str(last))
            self.assertGreater(last.marginalized_nodes, 0)
            self.assertGreater(last.last_online_trim_sec, 0.0)
            self.assertLessEqual(last.session, 1)  # 0 once the first session left whole
            self.assertLess(last.nodes, 2 * loaded, str(last))
            self.save_map_of("online_trim", "online.rrrmap")
        finally:
            node.terminate()
            output, _ = node.communicate(timeout=30)
        self.assertIn("lifelong: trimmed", output)

    def test_f_one_endless_session_trims_its_own_older_submaps(self):
        # No map: one session that drives its path there and back. With keep_current_session
        # off, its own older submaps go while it maps, once it came back over them.
        node, status = self.start_node("endless", {
            "input_mode": "scan", "publish_tf": False, "scans_per_submap": 10,
            "min_node_separation": 15, "lifelong": True, "keep_current_session": False,
            "trim_overlap_ratio": 0.5, "keep_recent_submaps": 2, "trim_every_n_nodes": 10})
        try:
            self.assertTrue(wait_for(lambda: "last" in status, 30.0), "the node did not start")
            there_and_back = os.path.join(self.folder, "there_and_back.clf")
            write_there_and_back_log(self.log, there_and_back)
            self.play(there_and_back, "replay_endless")
            self.assertTrue(wait_for(lambda: status["last"].online_trims > 0 and
                                     status["last"].trimmed_submaps > 0, 20.0), str(status["last"]))
            last = status["last"]
            self.assertGreater(last.marginalized_nodes, 0)
            self.assertLess(last.nodes, 150, str(last))  # untrimmed: 191 (rrr_slam_offline)
            self.save_map_of("endless", "endless.rrrmap")
        finally:
            node.terminate()
            output, _ = node.communicate(timeout=30)
        self.assertIn("lifelong: trimmed", output)

    def test_g_a_new_node_continues_the_saved_map_with_the_rest_of_the_drive(self):
        # The first part of a drive was mapped and saved (test_a: the minute there); a new node
        # starts with map_file, and the rest of the drive (the way back) is replayed with its
        # odometry moved by an arbitrary SE(2) and 700 s later: the node ties the new session to
        # the map, and its ~status and ~decisions show it.
        name = "continuer"
        node, status = self.start_node(name, {
            "input_mode": "scan", "map_file": self.map_path, "publish_tf": False,
            "scans_per_submap": 10, "min_node_separation": 15,
            "relocalization_confirm_distance": 2.0})
        decisions = []
        rospy.Subscriber(f"/{name}/decisions", LoopClosureDecision, decisions.append, queue_size=1000)
        try:
            self.assertTrue(wait_for(lambda: "last" in status, 30.0), "the node did not start")
            loaded = status["last"].nodes
            self.assertGreater(loaded, 30)
            self.assertEqual(status["last"].session, 1)
            self.assertFalse(status["last"].tied_to_map)
            back = os.path.join(self.folder, "back.clf")
            write_there_and_back_log(self.log, back, part="back")
            rest = os.path.join(self.folder, "rest_moved.clf")
            write_moved_log(back, rest, (-40.0, -60.0, -2.0), later=700.0)
            self.play(rest, "replay_rest")
            self.assertTrue(wait_for(lambda: status["last"].tied_to_map and status["last"].backlog == 0, 30.0),
                            str(status["last"]))
            self.assertGreater(status["last"].nodes, loaded + 30)
            self.assertGreaterEqual(status["last"].tied_after_sec, 0.0)
            final = {d.candidate: d for d in decisions}
            crossing = [d for d in final.values() if (d.from_id < loaded) != (d.to_id < loaded)
                        and d.verdict == LoopClosureDecision.ACCEPTED]
            self.assertTrue(crossing, "no accepted loop between the new session and the map")
        finally:
            node.terminate()
            node.wait(timeout=30)


if __name__ == "__main__":
    rostest.rosrun("rrr_graphslam", "sessions", Sessions)
