#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Behaviour 5: grasp and release at run time (grasp_release.test).

The tests run in order on one node: the rope swings under gravity between its clamp and the
gripper, 'mid' and 'near' grasp it, then every grasp is released.
"""
import time
import unittest

import numpy as np
import rospy
import rostest

import corde_rostest as ct
from corde_sim.srv import ListGrasps
from geometry_msgs.msg import WrenchStamped

N = 10
H = 2.5e-4  # s


def seg(s, k):
    return ct.segment_pose(s.rods[0], k)


def node_speed(s, i):
    return np.linalg.norm(ct.vec(s.rods[0].velocities[i]))


class GraspRelease(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("grasp_release_test")
        cls.sim = ct.Sim()
        assert cls.sim.state.last() is not None
        time.sleep(0.5)  # the rope sags and swings
        cls.sim.paused_state()

    def step(self, n):
        r = self.sim.step(n)
        self.assertTrue(r.success, r.message)
        s = self.sim.state_after(r.time)
        self.assertTrue(ct.finite_state(s))
        return s

    def assert_held(self, before, k, steps=400):
        """Segment k stays exactly where it was over `steps` steps, at rest."""
        p0, r0 = seg(before, k)
        s = self.step(steps)
        p, r = seg(s, k)
        self.assertLess(np.linalg.norm(p - p0), 1e-9, "held segment %d moved" % k)
        self.assertLess(ct.rotation_angle(r @ r0.T), 1e-9)
        self.assertLess(max(node_speed(s, k), node_speed(s, k + 1)), 1e-6)
        return s

    def test_1_grasp_at_arc_length_without_jerk(self):
        before = self.sim.fresh_state()
        self.assertGreater(node_speed(before, 4), 1e-3, "the rope should still be swinging")
        r = self.sim.grasp("mid", arc_length=0.225)  # the midpoint of segment 4
        self.assertTrue(r.success, r.message)
        self.assertEqual(r.segment, 4)
        # Grasping took the segment as it was: the state after the grasp shows it unmoved.
        after = self.sim.state_after(before.sim_time + 0.5 * H)
        self.assertGreater(after.sim_time, before.sim_time)  # a new stamp for the changed state
        for i in range(N + 1):
            self.assertLess(np.linalg.norm(ct.vec(after.rods[0].nodes[i]) -
                                           ct.vec(before.rods[0].nodes[i])), 1e-12)
        self.assert_held(after, 4)

    def test_2_grasp_nearest_point(self):
        s = self.sim.fresh_state()
        p7, _ = seg(s, 7)
        r = self.sim.grasp("near", point=p7 + np.array([0.01, -0.01, 0.005]))
        self.assertTrue(r.success, r.message)
        self.assertEqual(r.segment, 7)
        self.assert_held(self.sim.fresh_state(), 7)

    def test_3_grasp_errors(self):
        s = self.sim.fresh_state()
        for args, what in [
            (dict(name="gripper", arc_length=0.1), "name already held"),
            (dict(name="other", rod="cable", arc_length=0.1), "unknown rod"),
            (dict(name="other", arc_length=-0.01), "negative arc length"),
            (dict(name="other", arc_length=0.6), "beyond the rest length 0.5 m"),
            (dict(name="other", arc_length=float("nan")), "NaN arc length"),
            (dict(name="other", point=(float("nan"), 0, 0)), "NaN point"),
            (dict(name="bad/name", arc_length=0.1), "invalid name"),
            (dict(name="", arc_length=0.1), "empty name"),
            (dict(name="other", arc_length=0.1, source="magic"), "unknown source"),
            (dict(name="other", arc_length=0.1, source="tf"), "tf source without frame"),
            (dict(name="other", arc_length=0.0), "the clamped first segment"),
        ]:
            r = self.sim.grasp(**args)
            self.assertFalse(r.success, what)
            self.assertEqual(r.segment, -1, what)
            self.assertTrue(r.message, what)
        for name in ["nobody", ""]:
            r = self.sim.release(name)
            self.assertFalse(r.success)
            self.assertTrue(r.message)
        # Nothing changed: same time, same state.
        s2 = self.sim.fresh_state()
        self.assertEqual(s2.sim_time, s.sim_time)
        self.assertEqual(s2.rods[0].nodes, s.rods[0].nodes)

    def test_4_released_segments_move_freely(self):
        # From the end inwards, so that each release frees a longer piece that sags: the end
        # segment hangs from 'near' (0.1 m), then 'near' from 'mid', then all from the clamp.
        for name, k in [("gripper", 9), ("near", 7), ("mid", 4)]:
            before = self.sim.fresh_state()
            r = self.sim.release(name)
            self.assertTrue(r.success, r.message)
            self.assertFalse(self.sim.release(name).success, "released twice")
            p0, _ = seg(before, k)
            first = self.step(1)
            # No jump at release: one step from rest moves it by about g h^2.
            self.assertLess(np.linalg.norm(seg(first, k)[0] - p0), 1e-4)
            # It falls (a held segment moves less than 1e-9 m): the largest drop over 0.2 s, as
            # the freed piece swings.
            drop = max(p0[2] - seg(self.step(100), k)[0][2] for _ in range(8))
            self.assertGreater(drop, 5e-3, "released segment %d did not fall" % k)
        # The clamp still holds node 0.
        s = self.sim.fresh_state()
        self.assertLess(np.linalg.norm(ct.vec(s.rods[0].nodes[0]) - np.array([0, 0, 1])), 1e-12)

    def test_5_grasp_again_after_release(self):
        r = self.sim.grasp("gripper", arc_length=0.475)
        self.assertTrue(r.success, r.message)
        self.assertEqual(r.segment, 9)
        self.assert_held(self.sim.fresh_state(), 9)

    def test_6_wrench_sent_before_release_applies_before_it(self):
        # Paused, so the wrench waits in the node until the ~release: inputs and services take
        # effect in the order they arrived. The released grasp keeps its wrench (and its entry).
        r = self.sim.grasp("pushed", arc_length=0.325)
        self.assertTrue(r.success, r.message)
        pub = rospy.Publisher("/grasps/pushed/wrench", WrenchStamped, queue_size=5)
        self.assertTrue(ct.wait_connected(pub))
        w = WrenchStamped()
        w.header.frame_id = "world"
        w.header.stamp = rospy.Time.now()
        w.wrench.force.z = -0.5
        pub.publish(w)
        time.sleep(0.5)  # received and queued by the node
        r = self.sim.release("pushed")
        self.assertTrue(r.success, r.message)
        self.assertNotIn("topics end", r.message)
        listed = self.sim.service("list_grasps", ListGrasps)()
        self.assertIn("pushed", listed.names)
        self.assertFalse(listed.held[listed.names.index("pushed")])


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "grasp_release", GraspRelease)
