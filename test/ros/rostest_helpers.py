"""What the rostest scripts of this folder share."""
import time

import rospy


def wait_for(condition, timeout=60.0, poll=0.02):
    """Polls `condition` until it holds, the timeout passes or ROS shuts down; its last value."""
    deadline = time.monotonic() + timeout
    while not condition() and time.monotonic() < deadline and not rospy.is_shutdown():
        time.sleep(poll)
    return condition()
