#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Behaviour 13: two namespaced instances side by side (namespaces.test)."""
import time
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import PoseStamped

import corde_rostest as ct

N = 10
TARGET = np.array([0.4, 0.1, 1.1])  # m: where sim1's gripper is moved (its end starts at 0.475, 0, 1)


class Namespaces(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("namespaces_test")
        cls.sims = {ns: ct.Sim(ns="/" + ns, private_ns="/%s/sim" % ns) for ns in ("sim1", "sim2")}
        for s in cls.sims.values():
            assert s.state.last() is not None

    def test_1_frames_carry_the_namespace(self):
        for ns, sim in self.sims.items():
            tf = sim.tf.wait(5)
            self.assertGreaterEqual(len(tf), 5, ns)
            children = {t.child_frame_id for m in tf for t in m.transforms}
            for k in range(N):
                self.assertIn("%s/rope/seg_%d" % (ns, k), children)
            self.assertTrue(all(c.startswith(ns + "/") for c in children), children)

    def test_2_a_pose_moves_only_its_own_instance(self):
        pub = rospy.Publisher("/sim1/grasps/gripper/pose", PoseStamped, queue_size=10)
        self.assertTrue(ct.wait_connected(pub))
        end = time.monotonic() + 1.5
        while time.monotonic() < end:
            pub.publish(ct.pose_msg(TARGET, np.eye(3)))
            time.sleep(0.05)
        time.sleep(0.2)
        p1, _ = ct.segment_pose(self.sims["sim1"].fresh_state().rods[0], N - 1)
        p2, _ = ct.segment_pose(self.sims["sim2"].fresh_state().rods[0], N - 1)
        self.assertLess(np.linalg.norm(p1 - TARGET), 1e-3)
        self.assertLess(np.linalg.norm(p2 - np.array([0.475, 0.0, 1.0])), 1e-6)

    def test_3_services_are_per_instance(self):
        r = self.sims["sim1"].pause(True)
        self.assertTrue(r.success, r.message)
        s1 = self.sims["sim1"].state.last(ct.WAIT, since=time.monotonic(), pred=lambda m: m.paused)
        self.assertIsNotNone(s1)
        a = self.sims["sim2"].fresh_state()
        time.sleep(0.5)
        b = self.sims["sim2"].fresh_state()
        self.assertFalse(b.paused)
        self.assertGreater(b.sim_time, a.sim_time + 0.3)  # sim2 keeps running
        c = self.sims["sim1"].fresh_state()
        self.assertTrue(c.paused)
        self.assertEqual(c.sim_time, s1.sim_time)  # sim1 stands still
        self.assertTrue(self.sims["sim1"].pause(False).success)


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "namespaces", Namespaces)
