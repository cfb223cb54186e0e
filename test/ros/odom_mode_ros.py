#!/usr/bin/python3
"""rostest for odometry input: a CARMEN log's Odometry messages become nodes exactly where the
keyframe rule (min_travel_m / min_rotation_rad since the last node) says, and the path follows."""
import math
import os
import subprocess
import sys
import time
import unittest

import rospy
import rostest
from nav_msgs.msg import Path

from rrr_graphslam.carmen import odometry_stream, read_carmen  # noqa: E402
from rrr_graphslam.graph_io import between  # noqa: E402
from rrr_graphslam.msg import RrrStatus  # noqa: E402

NODE = "/rrr_graphslam"


def expected_nodes(poses, min_travel, min_rotation):
    last, count = None, 0
    for p in poses:
        if last is not None:
            d = between(last, p)
            if math.hypot(d[0], d[1]) < min_travel and abs(d[2]) < min_rotation:
                continue
        last, count = p, count + 1
    return count


class OdomMode(unittest.TestCase):
    def test_nodes_follow_the_keyframe_rule(self):
        rospy.init_node("odom_mode_test")
        status, path = [None], [None]
        rospy.Subscriber(NODE + "/status", RrrStatus, lambda m: status.__setitem__(0, m), queue_size=10)
        rospy.Subscriber(NODE + "/path", Path, lambda m: path.__setitem__(0, m), queue_size=10)
        here = os.path.dirname(os.path.abspath(__file__))
        log_path = os.path.join(here, "..", "data", rospy.get_param("~log"))
        replay = os.path.join(here, "..", "..", "scripts", "replay_carmen")
        env = dict(os.environ, PATH="/usr/bin:" + os.environ.get("PATH", ""))
        rospy.wait_for_service(NODE + "/finish", timeout=30.0)
        result = subprocess.run([sys.executable, replay, log_path, "--rate", "5", "__name:=replay_odom_test"],
                                env=env, capture_output=True, text=True, timeout=100)
        self.assertEqual(result.returncode, 0, result.stdout + result.stderr)
        odometry = [pose for _, pose, _, _ in odometry_stream(read_carmen(log_path))]
        want = expected_nodes(odometry, rospy.get_param(NODE + "/min_travel_m"),
                              rospy.get_param(NODE + "/min_rotation_rad"))
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and not (
                status[0] and status[0].backlog == 0 and status[0].nodes == want):
            time.sleep(0.1)
        s = status[0]
        self.assertEqual(s.input_mode, "odom")
        self.assertEqual(s.nodes, want)
        self.assertEqual(s.messages_malformed, 0)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and not (path[0] and len(path[0].poses) == want):
            time.sleep(0.1)
        self.assertEqual(len(path[0].poses), want)
        # The path ends where the odometry does (no loops: map == odom).
        end = path[0].poses[-1].pose.position
        self.assertAlmostEqual(end.x, odometry[-1][0], delta=0.5)


if __name__ == "__main__":
    rostest.rosrun("rrr_graphslam", "odom_mode", OdomMode)
