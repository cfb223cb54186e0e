#!/usr/bin/python3
"""rostest: rrr_graphslam_node started with one bad private parameter at a time exits non-zero
and prints the parameter's name, value and valid range (the tables of rrr_params.h and
laser_slam_params.h); good values of every type (ints for doubles, lists of ints) start it."""
import os
import subprocess
import unittest

import roslib.packages
import rospy
import rostest

NODE = "param_check"

BAD = [
    ({"alpha": 1.5}, "alpha = 1.5 is out of range: must be in [1e-06, 0.999999999]"),
    ({"min_score": 2.0}, "min_score = 2 is out of range: must be in [0, 1]"),
    ({"scans_per_submap": 1}, "scans_per_submap = 1 is out of range: must be in [2, 1000000]"),
    ({"scan_refinement": "icp2"}, "scan_refinement must be least_squares or icp, not 'icp2'"),
    ({"scan_odometry_stddev": [0.1, 0.1, -1]},
     "scan_odometry_stddev = [0.1, 0.1, -1] is out of range: must be in [1e-06, 10]"),
    ({"scan_odometry_stddev": [0.1, 0.1]}, "scan_odometry_stddev must be a list of 3 numbers"),
    ({"cluster_gap": 0}, "cluster_gap = 0 is out of range online"),
    ({"joint_link_check": "yes"}, "joint_link_check has the wrong type"),
    ({"preset": "papers"}, "must be default or paper"),
    ({"angular_search_window": 4.0}, "angular_search_window = 4 is out of range: must be in [0, 3.14159265359]"),
    ({"input_mode": "scan", "map_file": "/nonexistent/map.rrrmap"},
     "/nonexistent/map.rrrmap: cannot open the map file"),
    ({"input_mode": "odom", "map_file": "/tmp/map.rrrmap"}, "map_file needs input_mode scan"),
    ({"input_mode": "scan", "mode": "localisation"}, "mode must be mapping or localization"),
    ({"input_mode": "scan", "mode": "localization"}, "mode localization needs a map to localize in"),
    ({"trim_overlap_ratio": 1.5}, "trim_overlap_ratio must be in (0, 1], got 1.5"),
    ({"keep_recent_submaps": 0}, "keep_recent_submaps must be at least 1, got 0"),
    ({"trim_rule": "fresh"}, "trim_rule must be overlap-ratio or fresh-area"),
    ({"trim_min_fresh_area_m2": -2.0}, "trim_min_fresh_area_m2 must be at least 0 (m^2), got -2"),
    ({"sparsification": "exact"}, "sparsification must be clt, dense or delete"),
    ({"trim_every_n_nodes": -1}, "trim_every_n_nodes must be at least 0"),
    ({"trim_every_n_nodes": 10}, "online trimming needs lifelong true"),
    ({"lifelong": True, "trim_every_n_nodes": 10, "sparsification": "delete"},
     "online trimming needs sparsification clt"),
    ({"map_layering": "newest"}, "map_layering must be all or newest-session"),
    ({"map_miss_probability": 0.6}, "map_miss_probability = 0.6 is out of range: must be in [0.01, 0.499]"),
    ({"verifier": "ransac"}, "verifier must be rrr, pcm, scgp or gnc, not 'ransac'"),
    ({"gnc_loss": "huber"}, "gnc_loss must be tls or gm, not 'huber'"),
    ({"scgp_ratio": 0.5}, "scgp_ratio must be at least 1, got 0.5"),
]


class Parameters(unittest.TestCase):
    def start(self, params, seconds):
        rospy.delete_param("/" + NODE) if rospy.has_param("/" + NODE) else None
        for name, value in params.items():
            rospy.set_param(f"/{NODE}/{name}", value)
        node = roslib.packages.find_node("rrr_graphslam", "rrr_graphslam_node")[0]
        env = dict(os.environ, ROSCONSOLE_STDOUT_LINE_BUFFERED="1")
        try:
            done = subprocess.run([node, f"__name:={NODE}"], capture_output=True, text=True,
                                  timeout=seconds, env=env)
            return done.returncode, done.stdout + done.stderr
        except subprocess.TimeoutExpired:
            return None, ""

    def test_bad_values_are_named(self):
        for params, message in BAD:
            code, output = self.start(params, 30)
            self.assertEqual(code, 1, f"{params}: {output}")
            self.assertIn(message, output, f"{params}")
            self.assertIn("FATAL", output)

    def test_good_values_of_every_type_start(self):
        # Still running after 3 s: nothing was refused.
        code, output = self.start({"scan_odometry_stddev": [1, 1, 1], "odometry_stddev": [1, 1, 1],
                                   "scan_max_range": 20, "scan_refinement": "icp",
                                   "joint_link_check": False, "preset": "paper",
                                   "loop_search_threads": 1, "lifelong": True,
                                   "trim_every_n_nodes": 50, "map_layering": "newest-session",
                                   "map_hit_probability": 0.7, "map_miss_probability": 0.4,
                                   "verifier": "gnc", "gnc_loss": "gm", "scgp_ratio": 3}, 3)
        self.assertIsNone(code, output)


if __name__ == "__main__":
    rospy.init_node("parameters_test")
    rostest.rosrun("rrr_graphslam", "parameters", Parameters)
