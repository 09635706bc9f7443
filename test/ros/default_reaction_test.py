#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""The gripper's reaction on the default scene (default_reaction.test)."""
import time
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import WrenchStamped

import corde_rostest as ct

MU = 2000 * np.pi * 0.003 ** 2  # kg/m: soft_cable (rho = 2000), r = 3 mm
G = 9.81


class DefaultReaction(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("default_reaction_test")
        cls.sim = ct.Sim()
        cls.reaction = ct.Recorder("/grasps/gripper/reaction", WrenchStamped)
        assert cls.sim.state.last() is not None

    def test_gripper_carries_half_the_cords_weight(self):
        # The cord hangs between the clamp and the gripper at the same height, its shape
        # symmetric: each carries half its weight (statics: the gripper 0.2755 N of 0.5520 N, the
        # grasp holding a whole segment where the clamp holds a node). Started as an arc, the cord
        # still swings after 4 s (backward Euler damps its slow sway little): the vertical pull
        # varies by about 1.2% about the static value, within the 3% allowed here.
        self.sim.paused_state()
        self.addCleanup(self.sim.pause, False)
        self.assertTrue(self.sim.step(2000).success)  # 4 s at 2 ms
        time.sleep(0.6)  # the 2000 steps' wrench is out (state ticks run at 2 Hz or more)
        since = time.monotonic()
        r = self.sim.step(250)
        self.assertTrue(r.success, r.message)
        w = self.reaction.last(since=since)
        self.assertIsNotNone(w, "no reaction wrench")
        self.assertEqual(w.header.frame_id, "grasp/gripper")
        s = self.sim.state_after(r.time)
        rod = s.rods[0]
        n = len(rod.tension)
        # The holder frame is the held (last) segment's frame: the force in the world frame.
        _, rot = ct.segment_pose(rod, n - 1)
        f = rot.dot(ct.vec(w.wrench.force))
        x = np.array([ct.vec(p) for p in rod.nodes])
        length = np.sum(np.linalg.norm(np.diff(x, axis=0), axis=1))
        half = 0.5 * MU * length * G
        print("gripper force (world) %s N, half the weight %.6f N" % (f, half))
        self.assertGreater(np.linalg.norm(f), 0.5 * half, "reaction %s N: none" % f)
        self.assertLess(abs(-f[2] - half), 0.03 * half, "reaction %s N, half weight %g N" % (f, half))
        # The cord pulls the gripper towards the clamp (at x = 0), in the plane it hangs in.
        self.assertLess(f[0], -0.1 * half)
        self.assertLess(abs(f[1]), 1e-6 * half)


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "default_reaction", DefaultReaction)
