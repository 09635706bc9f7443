#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""dynamic_reconfigure of the running node (reconfigure.test)."""
import time
import unittest

import numpy as np
import rospy
import rostest
from dynamic_reconfigure.client import Client
from geometry_msgs.msg import PoseStamped
from visualization_msgs.msg import Marker, MarkerArray

import corde_rostest as ct

N = 10


class Reconfigure(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("reconfigure_test")
        cls.sim = ct.Sim()
        cls.markers = ct.Recorder("/markers", MarkerArray)
        cls.client = Client("/sim", timeout=ct.WAIT)
        assert cls.sim.state.last() is not None

    def rate(self, recorder, seconds=2.0):
        since = time.monotonic()
        time.sleep(seconds)
        return len(recorder.messages(since)) / seconds

    def test_1_rates(self):
        self.assertAlmostEqual(self.rate(self.sim.state), 50.0, delta=10.0)
        self.client.update_configuration({"state_rate": 10.0, "tf_rate": 5.0})
        time.sleep(0.3)
        self.assertAlmostEqual(self.rate(self.sim.state), 10.0, delta=2.5)
        self.assertAlmostEqual(self.rate(self.sim.tf), 5.0, delta=1.5)
        self.client.update_configuration({"state_rate": 50.0, "tf_rate": 50.0})

    def test_2_marker_style(self):
        def types():
            m = self.markers.last(since=time.monotonic())
            return {k.type for k in m.markers if k.ns == "rope"}
        self.assertEqual(types(), {Marker.CYLINDER})
        self.client.update_configuration({"marker_style": "line_strip"})
        time.sleep(0.3)
        self.assertEqual(types(), {Marker.LINE_STRIP})
        # An unknown style (`dynparam set /sim marker_style bogus`) is refused: kept, and the
        # reply shows the kept one (issue 24, item 11).
        c = self.client.update_configuration({"marker_style": "bogus"})
        self.assertEqual(c["marker_style"], "line_strip")
        time.sleep(0.3)
        self.assertEqual(types(), {Marker.LINE_STRIP})
        self.client.update_configuration({"marker_style": "cylinders"})

    def test_3_holder_speed(self):
        # A slower holder: a 0.2 m jump is covered at no more than 0.1 m/s.
        self.client.update_configuration({"holder_max_speed": 0.1})
        s0 = self.sim.fresh_state()
        p0, r0 = ct.segment_pose(s0.rods[0], N - 1)
        pub = rospy.Publisher("/grasps/gripper/pose", PoseStamped, queue_size=10)
        self.assertTrue(ct.wait_connected(pub))
        since = time.monotonic()
        for _ in range(10):
            pub.publish(ct.pose_msg(p0 + np.array([-0.2, 0, 0]), r0))
            time.sleep(0.05)
        time.sleep(0.5)
        speeds = [np.linalg.norm(ct.vec(s.rods[0].velocities[N])) for s in self.sim.state.messages(since)]
        self.assertGreater(max(speeds), 0.09)
        self.assertLess(max(speeds), 0.1 * 1.01)
        self.client.update_configuration({"holder_max_speed": 2.0})


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "reconfigure", Reconfigure)
