#!/usr/bin/python3
"""rostest for slam mode: replays a CARMEN log (LaserScan, odom -> base_link tf, /clock) into the
node and checks what a user sees in rviz: a latched map with walls and free space in the map frame,
loop decisions, the path and map -> odom, and no scan dropped."""
import os
import subprocess
import sys
import time
import unittest

import rospy
import rostest
from nav_msgs.msg import OccupancyGrid, Path
from std_srvs.srv import Trigger
from tf2_msgs.msg import TFMessage

from rrr_graphslam.msg import LoopClosureDecision, RrrStatus  # noqa: E402
from rostest_helpers import wait_for  # noqa: E402


NODE = "/rrr_graphslam"


class SlamMode(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("slam_mode_test")
        cls.maps, cls.decisions, cls.tf, cls.status, cls.path = [], [], [], None, None
        rospy.Subscriber("/map", OccupancyGrid, cls.maps.append, queue_size=10)
        rospy.Subscriber(NODE + "/decisions", LoopClosureDecision, cls.decisions.append, queue_size=1000)
        rospy.Subscriber(NODE + "/status", RrrStatus, lambda m: setattr(cls, "status", m), queue_size=10)
        rospy.Subscriber(NODE + "/path", Path, lambda m: setattr(cls, "path", m), queue_size=10)
        rospy.Subscriber("/tf", TFMessage, lambda m: cls.tf.extend(
            t for t in m.transforms if t.header.frame_id == "map"), queue_size=1000)
        rospy.wait_for_service(NODE + "/finish", timeout=30.0)
        wait_for(lambda: cls.status is not None, 30.0)
        here = os.path.dirname(os.path.abspath(__file__))
        log = os.path.join(here, "..", "data", rospy.get_param("~log"))
        replay = os.path.join(here, "..", "..", "scripts", "replay_carmen")
        env = dict(os.environ, PATH="/usr/bin:" + os.environ.get("PATH", ""))
        result = subprocess.run([sys.executable, replay, log, "--rate", str(rospy.get_param("~rate", 3.0)),
                                 "__name:=replay_carmen_test"], env=env, capture_output=True, text=True,
                                timeout=150)
        cls.replay_output = result.stdout + result.stderr
        cls.replay_code = result.returncode
        # Every scan processed, then every cluster decided and the final map published.
        wait_for(lambda: cls.status and cls.status.backlog == 0 and
                 cls.status.messages_processed == cls.status.messages_received, 60.0)
        cls.finish = rospy.ServiceProxy(NODE + "/finish", Trigger)()

    def test_replay_ran(self):
        self.assertEqual(self.replay_code, 0, self.replay_output)

    def test_every_scan_became_part_of_the_graph(self):
        s = self.status
        self.assertEqual(s.input_mode, "scan")
        self.assertEqual(s.messages_malformed, 0, f"scans dropped: {s}")
        self.assertGreater(s.nodes, 30)
        self.assertTrue(self.finish.success, self.finish.message)

    def test_map_is_published_latched_with_walls_and_free_space(self):
        self.assertTrue(wait_for(lambda: len(self.maps) > 0, 20.0), "no map on /map")
        grid = self.maps[-1]
        self.assertEqual(grid.header.frame_id, "map")
        self.assertAlmostEqual(grid.info.resolution, 0.05, places=6)
        data = grid.data
        self.assertEqual(len(data), grid.info.width * grid.info.height)
        occupied = sum(1 for v in data if v >= 65)
        free = sum(1 for v in data if 0 <= v <= 35)
        self.assertGreater(occupied, 500)
        self.assertGreater(free, 5 * occupied)
        # Latched: a late subscriber gets it too.
        late = rospy.wait_for_message("/map", OccupancyGrid, timeout=10.0)
        self.assertEqual(late.info.width, grid.info.width)

    def test_loop_candidates_were_proposed_and_decided(self):
        final = {}
        for d in self.decisions:
            final[d.candidate] = d.verdict
        self.assertGreater(len(final), 0, "no loop decisions")
        self.assertTrue(all(v != LoopClosureDecision.PENDING for v in final.values()))
        self.assertGreater(sum(v == LoopClosureDecision.ACCEPTED for v in final.values()), 0)
        self.assertEqual(self.status.candidates, len(final))
        # One session: every candidate the search around the estimate's (as rrr_map_info says).
        self.assertEqual({d.source for d in self.decisions}, {"local-search"})

    def test_path_and_map_to_odom(self):
        self.assertTrue(wait_for(lambda: self.path is not None and len(self.path.poses) == self.status.nodes, 10.0))
        self.assertTrue(self.tf, "no map -> odom on /tf")
        self.assertEqual(self.tf[-1].child_frame_id, "odom")


if __name__ == "__main__":
    rostest.rosrun("rrr_graphslam", "slam_mode", SlamMode)
