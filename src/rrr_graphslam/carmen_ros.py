"""A CARMEN log as ROS messages, for replay_carmen (live, with /clock) and carmen_to_bag (a bag):
sensor_msgs/LaserScan on `scan`, nav_msgs/Odometry on `odom`, tf odom -> base_link with every
odometry reading and a static base_link -> laser from the first scan. Readings at or above the
log's maximum become +inf (REP 117: no return)."""

import math
from dataclasses import dataclass
from typing import List, Tuple

import rospy
from geometry_msgs.msg import Quaternion, TransformStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

from .carmen import CarmenLog, LaserRecord, monotonic_stamps, odometry_stream


@dataclass
class Frames:
    odom: str = "odom"
    base: str = "base_link"
    laser: str = "laser"


def quaternion(yaw: float) -> Quaternion:
    return Quaternion(0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def transform(parent: str, child: str, stamp, pose) -> TransformStamped:
    t = TransformStamped()
    t.header.stamp, t.header.frame_id, t.child_frame_id = stamp, parent, child
    t.transform.translation.x, t.transform.translation.y = pose[0], pose[1]
    t.transform.rotation = quaternion(pose[2])
    return t


def scan_message(record: LaserRecord, stamp, frame: str, max_range: float) -> LaserScan:
    msg = LaserScan()
    msg.header.stamp, msg.header.frame_id = stamp, frame
    msg.angle_min = record.angle_min
    msg.angle_increment = record.angle_increment
    msg.angle_max = record.angle_min + record.angle_increment * (len(record.ranges) - 1)
    msg.range_min = 0.0
    msg.range_max = max_range
    msg.ranges = [r if r < max_range else math.inf for r in record.ranges]
    return msg


def log_messages(log: CarmenLog, frames: Frames = Frames()) -> Tuple[List[Tuple[float, str, object]], int]:
    """(time, topic, message) in log order, a /tf_static first; and how many timestamps had to be
    moved forward because the log's went back (each stream's stamps are kept increasing on its
    own: odometry and scans may share a stamp)."""
    own_odometry = bool(log.odometry)
    odom_times, moved_odom = monotonic_stamps([t for t, *_ in odometry_stream(log)])
    scan_times, moved_scan = monotonic_stamps([r.timestamp for r in log.lasers])
    odometry = odometry_stream(log)
    out: List[Tuple[float, str, object]] = []
    start = min(odom_times[0] if odom_times else scan_times[0], scan_times[0])
    static = TFMessage([transform(frames.base, frames.laser, rospy.Time.from_sec(start), log.laser_offset())])
    out.append((start, "/tf_static", static))
    max_range = log.max_range
    k_odom = k_scan = 0

    def emit_odometry(k):
        t = odom_times[k]
        stamp = rospy.Time.from_sec(t)
        _, pose, tv, rv = odometry[k]
        msg = Odometry()
        msg.header.stamp, msg.header.frame_id, msg.child_frame_id = stamp, frames.odom, frames.base
        msg.pose.pose.position.x, msg.pose.pose.position.y = pose[0], pose[1]
        msg.pose.pose.orientation = quaternion(pose[2])
        msg.twist.twist.linear.x, msg.twist.twist.angular.z = tv, rv
        out.append((t, "odom", msg))
        out.append((t, "/tf", TFMessage([transform(frames.odom, frames.base, stamp, pose)])))

    for record in log.records:
        if isinstance(record, LaserRecord):
            if not own_odometry:
                emit_odometry(k_scan)  # the scan's odometry, just before the scan
            t = scan_times[k_scan]
            out.append((t, "scan", scan_message(record, rospy.Time.from_sec(t), frames.laser, max_range)))
            k_scan += 1
        else:
            emit_odometry(k_odom)
            k_odom += 1
    return out, moved_odom + (moved_scan if own_odometry else 0)
