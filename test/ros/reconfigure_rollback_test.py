#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Issue 23: configuration is never reverted by a rollback (reconfigure_rollback.test)."""
import time
import unittest

import numpy as np
import rospy
import rostest
from dynamic_reconfigure.client import Client
from geometry_msgs.msg import PoseStamped, WrenchStamped

import corde_rostest as ct

N = 10  # rope.yaml's elements
H = 2.5e-4  # s, rope.yaml's step


def wrench(fz):
    w = WrenchStamped()
    w.header.frame_id = "world"
    w.header.stamp = rospy.Time.now()
    w.wrench.force.z = fz
    return w


class ReconfigureRollback(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("reconfigure_rollback_test")
        cls.sim = ct.Sim()
        cls.client = Client("/sim", timeout=ct.WAIT)
        assert cls.sim.state.last() is not None

    def test_holder_limit_survives_rollback(self):
        self.sim.paused_state()
        # 'push' carries the force that makes the guard roll back; a released ~grasp grasp stays
        # (with its topics) while a wrench acts on it: a tiny one is set before the release.
        r = self.sim.grasp("push", arc_length=0.225)
        self.assertTrue(r.success, r.message)
        wrench_pub = rospy.Publisher("/grasps/push/wrench", WrenchStamped, queue_size=10)
        pose_pub = rospy.Publisher("/grasps/gripper/pose", PoseStamped, queue_size=10)
        self.assertTrue(ct.wait_connected(wrench_pub) and ct.wait_connected(pose_pub))
        wrench_pub.publish(wrench(1e-9))
        time.sleep(0.2)
        self.assertTrue(self.sim.step(1).success)
        self.assertTrue(self.sim.release("push").success)
        # The guard's snapshot: taken after these steps, with the holder limit at 2 m/s.
        self.assertTrue(self.sim.step(10).success)
        c = self.client.update_configuration({"holder_max_speed": 0.1})
        self.assertEqual(c["holder_max_speed"], 0.1)
        time.sleep(0.3)  # (applied by the loop)
        # An absurd force: every retry fails, the world goes back to the snapshot.
        for _ in range(5):
            wrench_pub.publish(wrench(1e200))
            time.sleep(0.1)
        r = self.sim.step(200)
        self.assertFalse(r.success, "the force should have stopped the simulation: " + r.message)
        self.assertIn("stopped at the last good state", r.message)
        # ~configure resumes (the guard starts over from the state rolled back to).
        r = self.sim.configure(["time_step"], [H])
        self.assertTrue(r.success, r.message)
        # A 0.2 m jump of the gripper is covered at no more than the new 0.1 m/s.
        s0 = self.sim.fresh_state()
        p0, r0 = ct.segment_pose(s0.rods[0], N - 1)
        for _ in range(5):
            pose_pub.publish(ct.pose_msg(p0 + np.array([-0.2, 0, 0]), r0))
            time.sleep(0.05)
        r = self.sim.step(4000)  # 1 s
        self.assertTrue(r.success, r.message)
        s1 = self.sim.state_after(r.time)
        moved = np.linalg.norm(ct.vec(s1.rods[0].nodes[N]) - ct.vec(s0.rods[0].nodes[N]))
        print("the gripper moved %.4f m in 1 s" % moved)
        self.assertGreater(moved, 0.09)
        self.assertLess(moved, 0.1 * 1.01,
                        "the gripper moved %.3f m in 1 s: the rollback brought back the old "
                        "holder_max_speed" % moved)

if __name__ == "__main__":
    rostest.rosrun("corde_sim", "reconfigure_rollback", ReconfigureRollback)
