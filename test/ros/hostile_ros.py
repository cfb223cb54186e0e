#!/usr/bin/python3
"""rostest: hostile input to the node in slam mode. Each case is sent between valid scans of a
robot driving through a rectangular room; after each, the node must answer ~optimize within a
second, count the bad message in ~status (messages_malformed or messages_ignored), and process
the valid scans that follow."""
import math
import time
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import LaserScan
from std_srvs.srv import Trigger
from tf2_msgs.msg import TFMessage

from rrr_graphslam.msg import LoopCandidate, PoseGraphEdge, RrrStatus  # noqa: E402
from rostest_helpers import wait_for  # noqa: E402


NODE = "/rrr_graphslam"
ROOM = (-4.0, 6.0, -3.0, 5.0)  # x_min, x_max, y_min, y_max of the walls (m)


def room_ranges(x, y, yaw, n=360):
    angles = yaw - math.pi + np.arange(n) * (2 * math.pi / n)
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore", invalid="ignore"):
        tx = np.where(c > 0, (ROOM[1] - x) / c, np.where(c < 0, (ROOM[0] - x) / c, np.inf))
        ty = np.where(s > 0, (ROOM[3] - y) / s, np.where(s < 0, (ROOM[2] - y) / s, np.inf))
    return np.minimum(tx, ty).astype(np.float32)


def transform(parent, child, stamp, x, y, yaw):
    t = TransformStamped()
    t.header.stamp, t.header.frame_id, t.child_frame_id = stamp, parent, child
    t.transform.translation.x, t.transform.translation.y = x, y
    t.transform.rotation.z, t.transform.rotation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return t


class Hostile(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("hostile_test")
        cls.status = None
        rospy.Subscriber(NODE + "/status", RrrStatus, lambda m: setattr(cls, "status", m), queue_size=10)
        cls.scan_pub = rospy.Publisher("/scan", LaserScan, queue_size=100)
        cls.tf_pub = rospy.Publisher("/tf", TFMessage, queue_size=100)
        cls.edge_pub = rospy.Publisher("/pose_graph_edges", PoseGraphEdge, queue_size=100)
        cls.candidate_pub = rospy.Publisher("/loop_candidates", LoopCandidate, queue_size=100)
        rospy.wait_for_service(NODE + "/optimize", timeout=30.0)
        cls.optimize = rospy.ServiceProxy(NODE + "/optimize", Trigger)
        # The node's tf listener too: a first tf message sent before it connects is lost, and the
        # first scan, its transform never seen, counts as malformed.
        assert wait_for(lambda: cls.scan_pub.get_num_connections() > 0 and
                        cls.tf_pub.get_num_connections() > 0 and cls.status is not None, 30.0)
        cls.k = 0

    def scan_message(self, stamp, frame="laser", ranges=None):
        msg = LaserScan()
        msg.header.stamp, msg.header.frame_id = stamp, frame
        msg.angle_min, msg.angle_increment = -math.pi, 2 * math.pi / 360
        msg.angle_max = msg.angle_min + 359 * msg.angle_increment
        msg.range_min, msg.range_max = 0.1, 30.0
        msg.ranges = list(ranges) if ranges is not None else []
        return msg

    def send_valid(self, count=3):
        """Scans of the robot driving along x, with their tf; returns how many were sent."""
        for _ in range(count):
            self.__class__.k += 1
            x, y, yaw = 0.05 * self.k, 0.02 * self.k, 0.01 * self.k
            stamp = rospy.Time.now()
            self.tf_pub.publish(TFMessage([transform("odom", "base_link", stamp, x, y, yaw),
                                           transform("base_link", "laser", stamp, 0.1, 0.0, 0.0)]))
            time.sleep(0.02)
            self.scan_pub.publish(self.scan_message(stamp, ranges=room_ranges(x + 0.1, y, yaw)))
            time.sleep(0.05)
        return count

    def settled(self):
        s = self.status
        return s is not None and s.backlog == 0 and s.messages_processed == s.messages_received

    def check_alive_and_going_on(self, case, counter):
        """After one hostile case: a service answers within a second, the case is counted, and
        valid scans after it are processed."""
        start = time.monotonic()
        answer = self.optimize()
        self.assertLess(time.monotonic() - start, 1.0, f"{case}: ~optimize took too long")
        self.assertTrue(answer.success, f"{case}: {answer.message}")
        before = self.status.messages_processed
        bad_before = getattr(self.status, counter)
        self.send_valid(3)
        self.assertTrue(wait_for(lambda: self.settled() and self.status.messages_processed >= before + 3),
                        f"{case}: valid scans after it not processed ({self.status})")
        return bad_before

    def test_hostile_cases_in_turn(self):
        self.send_valid(5)
        self.assertTrue(wait_for(self.settled), "the first valid scans were not processed")
        self.assertEqual(self.status.messages_malformed, 0)

        def scan_case(name, publish, expected_malformed):
            malformed = self.status.messages_malformed
            publish()
            self.assertTrue(wait_for(lambda: self.status.messages_malformed >= malformed + expected_malformed),
                            f"{name}: not counted as malformed ({self.status})")
            self.check_alive_and_going_on(name, "messages_malformed")

        def odometry(x):
            def publish():
                stamp = rospy.Time.now()
                self.tf_pub.publish(TFMessage([transform("odom", "base_link", stamp, x, 0.0, 0.0),
                                               transform("base_link", "laser", stamp, 0.1, 0.0, 0.0)]))
                time.sleep(0.02)
                self.scan_pub.publish(self.scan_message(stamp, ranges=room_ranges(0.0, 0.0, 0.0)))
            return publish

        scan_case("odometry at 1e7 m", odometry(1e7), 1)
        scan_case("odometry at 1e300 m", odometry(1e300), 1)
        # A 1 km jump: refused, and the next valid scan too (the jump back; the odometry is
        # re-anchored at each), then tracking goes on.
        malformed = self.status.messages_malformed
        scan_case("odometry jump of 1 km", odometry(0.05 * self.k + 1000.0), 1)
        self.assertEqual(self.status.messages_malformed, malformed + 2)
        scan_case("unknown frame_id", lambda: self.scan_pub.publish(
            self.scan_message(rospy.Time.now(), frame="no_such_frame", ranges=room_ranges(0, 0, 0))), 1)
        scan_case("stamp far ahead of tf", lambda: self.scan_pub.publish(
            self.scan_message(rospy.Time.now() + rospy.Duration(1000.0), ranges=room_ranges(0, 0, 0))), 1)

        def bad_scan(**fields):
            def publish():
                stamp = rospy.Time.now()
                self.tf_pub.publish(TFMessage([transform("odom", "base_link", stamp, 0.05 * self.k, 0.02 * self.k, 0.01 * self.k),
                                               transform("base_link", "laser", stamp, 0.1, 0.0, 0.0)]))
                time.sleep(0.02)
                msg = self.scan_message(stamp, ranges=room_ranges(0.05 * self.k, 0.02 * self.k, 0.01 * self.k))
                for name, value in fields.items():
                    setattr(msg, name, value)
                self.scan_pub.publish(msg)
            return publish

        scan_case("zero angle_increment", bad_scan(angle_increment=0.0), 1)
        scan_case("range count mismatch", bad_scan(ranges=[1.0] * 17), 1)
        scan_case("NaN angle_min", bad_scan(angle_min=float("nan")), 1)

        # NaN and inf ranges are valid LaserScan content (REP 117: no return): processed, not refused.
        malformed = self.status.messages_malformed
        bad_scan(ranges=[float("nan")] * 180 + [float("inf")] * 180)()
        self.check_alive_and_going_on("NaN/inf ranges", "messages_malformed")
        self.assertEqual(self.status.messages_malformed, malformed)

        # The graph topics belong to other modes: extreme ids are counted as ignored, never crash.
        ignored = self.status.messages_ignored
        self.edge_pub.publish(PoseGraphEdge(from_id=2 ** 32 - 1, to_id=0))
        self.candidate_pub.publish(LoopCandidate(from_id=2 ** 32 - 1, to_id=2 ** 32 - 2))
        self.assertTrue(wait_for(lambda: self.status.messages_ignored + self.status.messages_malformed
                                 >= ignored + malformed + 2), f"graph messages not counted ({self.status})")
        self.check_alive_and_going_on("extreme ids", "messages_ignored")
        self.assertGreater(self.status.nodes, 5)


if __name__ == "__main__":
    rostest.rosrun("rrr_graphslam", "hostile", Hostile)
