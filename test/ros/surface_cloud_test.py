#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Issue 24 item 8: the rods' surface as a point cloud (surface_cloud.test).

The free rope of free_rope.yaml (8 segments, radius 5 mm), stepped while paused so that the
cloud and rod_state show the same state: 8 x 2 rings x 6 points, every point finite and on the
rope's surface (at the radius from its axis), in the world frame.
"""
import time
import unittest

import numpy as np
import rospy
import rostest
from sensor_msgs import point_cloud2
from sensor_msgs.msg import PointCloud2

import corde_rostest as ct

R = 0.005
SEGMENTS, RINGS, PER_RING = 8, 2, 6


def axis_distance(p, nodes):
    """Distance from p to the polyline through `nodes`."""
    best = np.inf
    for a, b in zip(nodes[:-1], nodes[1:]):
        d = b - a
        s = np.clip(np.dot(p - a, d) / np.dot(d, d), 0.0, 1.0)
        best = min(best, np.linalg.norm(a + s * d - p))
    return best


class SurfaceCloud(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("surface_cloud_test")
        cls.sim = ct.Sim()
        cls.cloud = ct.Recorder("/surface_cloud", PointCloud2)
        assert cls.sim.state.last() is not None

    def check(self):
        s = self.sim.fresh_state()
        self.assertTrue(s.paused)
        since = time.monotonic()
        c = self.cloud.last(since=since)
        self.assertIsNotNone(c, "no surface_cloud message")
        self.assertEqual(c.header.frame_id, "world")
        self.assertEqual(c.height, 1)
        self.assertEqual(c.width, SEGMENTS * RINGS * PER_RING)
        pts = np.array(list(point_cloud2.read_points(c, field_names=("x", "y", "z"))))
        self.assertEqual(pts.shape, (SEGMENTS * RINGS * PER_RING, 3))
        self.assertTrue(np.all(np.isfinite(pts)))
        nodes = np.array([ct.vec(n) for n in s.rods[0].nodes])
        d = np.array([axis_distance(p, nodes) for p in pts])
        self.assertLess(np.max(np.abs(d - R)), 1e-6, "points off the surface: %s" % (d - R))
        return s

    def test_1_cloud_on_the_surface(self):
        self.check()

    def test_2_cloud_follows_the_rope(self):
        before = self.check()
        r = self.sim.step(400)  # the rope falls 5 cm
        self.assertTrue(r.success, r.message)
        after = self.check()
        self.assertLess(after.rods[0].nodes[0].z, before.rods[0].nodes[0].z - 0.03)


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "surface_cloud", SurfaceCloud)
