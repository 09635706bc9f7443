#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Issue 24 item 7: run-time obstacles (runtime_obstacles.test).

The tests run in order on one node, paused, stepped through ~step: the free rope of
free_rope.yaml (level at z = 0.5 m, radius 5 mm) lands on a box added under it, falls when the
box is removed, and lands on a box posed in a tf frame, following it when the frame moves. Bad
requests are refused with messages naming what is wrong, and change nothing.
"""
import math
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import Point, Pose, TransformStamped
from shape_msgs.msg import Mesh, MeshTriangle, Plane, SolidPrimitive
from visualization_msgs.msg import Marker, MarkerArray

import corde_rostest as ct
from corde_sim.srv import AddObstacle, ListObstacles, RemoveObstacle

R = 0.005  # m: the rope's radius


def box_pose(x=0.0, y=0.0, z=0.0, q=(0.0, 0.0, 0.0, 1.0)):
    p = Pose()
    p.position.x, p.position.y, p.position.z = x, y, z
    p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w = q
    return p


def box(dims):
    s = SolidPrimitive()
    s.type = SolidPrimitive.BOX
    s.dimensions = list(dims)
    return s


def heights(s):
    return np.array([n.z for n in s.rods[0].nodes])


class RuntimeObstacles(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("runtime_obstacles_test")
        cls.sim = ct.Sim()
        assert cls.sim.state.last() is not None
        cls.add_srv = cls.sim.service("add_obstacle", AddObstacle)
        cls.remove_srv = cls.sim.service("remove_obstacle", RemoveObstacle)
        cls.list_srv = cls.sim.service("list_obstacles", ListObstacles)
        cls.tf_static = tf2_ros.StaticTransformBroadcaster()
        cls.markers = ct.Recorder("/markers", MarkerArray, queue_size=50)

    def add(self, name, primitive=None, pose=None, frame="", mesh=None, plane=None,
            friction=0.5, replace=False):
        return self.add_srv(name, frame, pose or box_pose(), primitive or SolidPrimitive(),
                            mesh or Mesh(), plane or Plane(), friction, replace)

    def step(self, n):
        r = self.sim.step(n)
        self.assertTrue(r.success, r.message)
        s = self.sim.state_after(r.time)
        self.assertTrue(ct.finite_state(s))
        return s

    def publish_fixture(self, z):
        t = TransformStamped()
        t.header.stamp = rospy.Time.now()
        t.header.frame_id = "world"
        t.child_frame_id = "fixture"
        t.transform.translation.z = z
        t.transform.rotation.w = 1.0
        self.tf_static.sendTransform(t)

    def listed(self):
        r = self.list_srv()
        return {n: (f, s, p) for n, f, s, p in zip(r.names, r.frames, r.shapes, r.poses)}

    def test_1_bad_requests_refused_nothing_changed(self):
        before = self.sim.fresh_state()
        self.assertTrue(before.paused)
        nan = float("nan")
        cases = [
            (dict(primitive=box((0.1, 0.1, 0.1)), pose=box_pose(nan)), "position is not finite"),
            (dict(primitive=box((0.1, 0.1, 0.1)), pose=box_pose(q=(0, 0, 0, 2))),
             "not a unit quaternion"),
            (dict(primitive=box((0.1, 1e9, 0.1))), "primitive.dimensions[1] (y) is 1e+09"),
            (dict(primitive=box((0.1, 0.1))), "BOX needs 3 dimensions"),
            (dict(primitive=box((0.1, 0.1, 0.1)), frame="nowhere"), "'nowhere' is unknown"),
            (dict(), "no shape"),
            (dict(primitive=box((0.1, 0.1, 0.1)), friction=-1.0), "friction is -1"),
            (dict(mesh=Mesh(triangles=[MeshTriangle(vertex_indices=[0, 1, 5])],
                            vertices=[Point(0, 0, 0), Point(1, 0, 0), Point(0, 1, 0)])),
             "mesh.triangles[0] has vertex index 5"),
            (dict(primitive=box((0.1, 0.1, 0.1)), pose=box_pose(1e6)),
             "has a position or size of 1e+06 m"),
        ]
        for kwargs, expected in cases:
            r = self.add("bad", **kwargs)
            self.assertFalse(r.success, "accepted: %s" % kwargs)
            self.assertIn(expected, r.message)
            self.assertIn("obstacle 'bad' not added", r.message)
        r = self.remove_srv("nothing")
        self.assertFalse(r.success)
        self.assertIn("no run-time obstacle is named 'nothing'", r.message)
        self.assertEqual(self.listed(), {})
        after = self.sim.fresh_state()
        self.assertEqual(after.steps, before.steps)
        self.assertTrue(np.array_equal(heights(after), heights(before)))

    def test_2_rope_rests_on_an_added_box(self):
        # Box top at z = 0.45: the rope falls 5 cm onto it and lies there.
        r = self.add("block", box((0.6, 0.2, 0.1)), box_pose(z=0.4))
        self.assertTrue(r.success, r.message)
        self.assertEqual(self.listed()["block"][:2], ("world", "box"))
        dup = self.add("block", box((0.6, 0.2, 0.1)), box_pose(z=0.4))
        self.assertFalse(dup.success)
        self.assertIn("was added already", dup.message)
        # Drawn like the scene's obstacles (namespace obstacles, a grey cube at its pose).
        def drawn(m):
            return [k for k in m.markers if k.ns == "obstacles" and k.type == Marker.CUBE and
                    abs(k.pose.position.z - 0.4) < 1e-9 and abs(k.scale.x - 0.6) < 1e-9]
        self.assertTrue(self.markers.wait(1, since=time.monotonic(), pred=drawn),
                        "the added box is not among the markers")
        s = self.step(4000)  # 1 s
        z = heights(s)
        self.assertLess(np.max(np.abs(z - (0.45 + R))), 1e-3, "rope not lying on the box: %s" % z)
        speed = max(np.linalg.norm(ct.vec(v)) for v in s.rods[0].velocities)
        self.assertLess(speed, 0.01)

    def test_3_removing_the_box_lets_it_fall(self):
        before = heights(self.sim.fresh_state())
        r = self.remove_srv("block")
        self.assertTrue(r.success, r.message)
        self.assertEqual(self.listed(), {})
        s = self.step(400)  # 0.1 s: free fall of 4.9 cm
        fell = before - heights(s)
        self.assertGreater(np.min(fell), 0.03, "rope did not fall: %s" % fell)
        self.assertFalse(self.remove_srv("block").success)

    def test_4_box_in_a_tf_frame_follows_it(self):
        # The rope is falling from about 0.41 m: a shelf in frame 'fixture' (at z = 0.2 m, the
        # box's top 5 cm above it) catches it; then the frame drops 10 cm and the shelf follows.
        self.publish_fixture(0.2)
        deadline = time.monotonic() + 10.0
        r = None
        while time.monotonic() < deadline:
            r = self.add("shelf", box((0.6, 0.2, 0.1)), frame="fixture")
            if r.success or "unknown" not in r.message:
                break
            time.sleep(0.1)
        self.assertTrue(r.success, r.message)
        frame, shape, pose = self.listed()["shelf"]
        self.assertEqual((frame, shape), ("fixture", "box"))
        self.assertAlmostEqual(pose.position.z, 0.2, places=9)
        s = self.step(6000)
        z = heights(s)
        self.assertLess(np.max(np.abs(z - (0.25 + R))), 1e-3, "rope not on the shelf: %s" % z)

        self.publish_fixture(0.1)
        deadline = time.monotonic() + 20.0
        while time.monotonic() < deadline:
            self.step(400)
            if abs(self.listed()["shelf"][2].position.z - 0.1) < 1e-9:
                break
        self.assertAlmostEqual(self.listed()["shelf"][2].position.z, 0.1, places=9)
        s = self.step(4000)
        z = heights(s)
        self.assertLess(np.max(np.abs(z - (0.15 + R))), 1e-3, "rope did not follow: %s" % z)
        # Replace moves it at once, in the world frame.
        r = self.add("shelf", box((0.6, 0.2, 0.1)), box_pose(z=-1.0), replace=True)
        self.assertTrue(r.success, r.message)
        self.assertEqual(self.listed()["shelf"][0], "world")
        self.assertAlmostEqual(self.listed()["shelf"][2].position.z, -1.0, places=9)

    def test_5_kept_through_reset(self):
        r = self.sim.reset()
        self.assertTrue(r.success, r.message)
        self.assertEqual(list(self.listed()), ["shelf"])
        # The shelf (its top at z = -0.95 since the replace) is an obstacle of the new world: the
        # rope, back at z = 0.5, falls 1.45 m and lands on it.
        s = self.step(8000)  # 2 s
        z = heights(s)
        self.assertLess(np.max(np.abs(z - (-0.95 + R))), 1e-3, "rope not on the shelf: %s" % z)

if __name__ == "__main__":
    rostest.rosrun("corde_sim", "runtime_obstacles", RuntimeObstacles)
