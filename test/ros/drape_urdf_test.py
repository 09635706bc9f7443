#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""The drape scene with its URDF obstacles in the node (drape_urdf.test): the table's top, four
legs and the bar are published as obstacle markers at their places, and the cord, dropped 3 cm,
lies on the table top rather than falling through it."""
import unittest

import rospy
import rostest
from visualization_msgs.msg import Marker, MarkerArray

import corde_rostest as ct

TOP = 0.75  # m: the table's top face (urdf/table_with_bar.urdf)
RADIUS = 0.003  # m: the cord's


class DrapeUrdf(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("drape_urdf_test")
        cls.sim = ct.Sim()
        cls.markers = ct.Recorder("/markers", MarkerArray)

    def test_1_obstacle_markers_from_the_urdf(self):
        msg = self.markers.last(pred=lambda m: any(k.ns == "obstacles" for k in m.markers))
        self.assertIsNotNone(msg, "no obstacle markers")
        obstacles = [k for k in msg.markers if k.ns == "obstacles"]
        boxes = [k for k in obstacles if k.type == Marker.CUBE]
        cylinders = [k for k in obstacles if k.type == Marker.CYLINDER]
        self.assertEqual(len(boxes), 5, "the top and four legs")
        self.assertEqual(len(cylinders), 1, "the bar")
        top = max(boxes, key=lambda k: k.scale.x * k.scale.y)
        self.assertAlmostEqual(top.pose.position.z + 0.5 * top.scale.z, TOP, delta=1e-9)
        self.assertAlmostEqual(top.scale.x, 1.2, delta=1e-9)
        bar = cylinders[0]
        self.assertAlmostEqual(bar.pose.position.x, -0.1, delta=1e-9)
        self.assertAlmostEqual(bar.pose.position.z, TOP + 0.01, delta=1e-9)

    def test_2_cord_lands_on_the_table(self):
        # The fall of 3 cm takes 0.08 s; at 0.5 s the start of the cord rests on the top.
        s = self.sim.state_after(0.5, timeout=60.0)
        self.assertIsNotNone(s, "no rod_state at t >= 0.5 s")
        self.assertTrue(ct.valid_state(s))
        z0 = ct.vec(s.rods[0].nodes[0])[2]
        self.assertAlmostEqual(z0, TOP + RADIUS, delta=0.1 * RADIUS)


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "drape_urdf", DrapeUrdf)
