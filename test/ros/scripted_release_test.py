#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""A scene grasp with grasp_time and release_time: listed but not holding before grasp_time (the
rope's end falls), holding from then on (its keyframe reached, reactions published), let go at
release_time (the end falls again, no more reactions) (scripted_release.test, scene
test/ros/scenes/scripted_release.yaml). Poses published before grasp_time are refused and leave the
script running; ~release after release_time answers that the grasp is already released."""
import time
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import PoseStamped, WrenchStamped

import corde_rostest as ct
from corde_sim.srv import ListGrasps

N = 10
H = 2.5e-4  # the scene's time step (s)
POS_TOL = 1e-3  # m
LIFTED = np.array([0.4, 0.0, 1.0])  # the keyframe's world position, reached at 1.2 s


class ScriptedRelease(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("scripted_release_test")
        cls.sim = ct.Sim()
        cls.reactions = ct.Recorder("/grasps/gripper/reaction", WrenchStamped)
        cls.pose_pub = rospy.Publisher("/grasps/gripper/pose", PoseStamped, queue_size=10)

    def grasp(self):
        r = self.sim.service("list_grasps", ListGrasps)()
        self.assertEqual(list(r.names), ["gripper"])
        return r.held[0], r.sources[0]

    def step_to(self, t):
        now = self.sim.state.last(pred=lambda m: m.paused).sim_time
        n = int(round((t - now) / H))
        r = self.sim.step(n)
        self.assertTrue(r.success, r.message)
        s = self.sim.state_after(r.time)
        self.assertIsNotNone(s, "no rod_state at %g s" % r.time)
        return s

    def test_grasp_and_release(self):
        s0 = ct.wait_for_node(self.sim, self)
        self.assertTrue(s0.paused)
        p0, _ = ct.segment_pose(s0.rods[0], N - 1)
        self.assertEqual(self.grasp(), (False, "scripted"))

        # Before grasp_time: nothing holds the end, it swings down.
        s = self.step_to(0.3)
        p, _ = ct.segment_pose(s.rods[0], N - 1)
        self.assertLess(p[2], p0[2] - 0.01, "the end did not fall before grasp_time")
        self.assertEqual(self.grasp(), (False, "scripted"))
        self.assertEqual(self.reactions.messages(), [])

        # A pose stream before grasp_time is refused: the script (and its grasp_time) stays.
        self.assertTrue(ct.wait_connected(self.pose_pub))
        for _ in range(5):
            self.pose_pub.publish(ct.pose_msg(LIFTED, np.eye(3)))
            time.sleep(0.05)
        time.sleep(0.5)
        self.step_to(0.35)  # (the node applies queued inputs when it steps)
        self.assertEqual(self.grasp(), (False, "scripted"))

        # From grasp_time: held where it was, then lifted to the keyframe and held there.
        s = self.step_to(0.55)
        self.assertEqual(self.grasp(), (True, "scripted"))
        s = self.step_to(1.3)
        p, _ = ct.segment_pose(s.rods[0], N - 1)
        self.assertLess(np.linalg.norm(p - LIFTED), POS_TOL, "held end at %s" % p)
        v = np.array([[w.x, w.y, w.z] for w in s.rods[0].velocities[-2:]])
        self.assertLess(np.abs(v).max(), 1e-3)
        self.assertTrue(self.reactions.wait(1), "no reaction while the grasp holds")
        self.assertTrue(ct.valid_state(s))

        # At release_time: let go; the end falls and no reaction follows.
        s = self.step_to(1.55)
        self.assertEqual(self.grasp(), (False, "scripted"))
        p, _ = ct.segment_pose(s.rods[0], N - 1)
        self.assertGreater(np.linalg.norm(p - LIFTED), 0.005, "the end stayed where it was held")
        time.sleep(1.0)  # the reaction of the last held steps may still be on its way
        since = time.monotonic()
        s = self.step_to(2.0)
        p, _ = ct.segment_pose(s.rods[0], N - 1)
        self.assertLess(p[2], LIFTED[2] - 0.01, "the end did not fall after release_time")
        self.assertEqual(self.grasp(), (False, "scripted"))
        time.sleep(1.0)
        self.assertEqual(self.reactions.messages(since), [])
        self.assertTrue(ct.valid_state(s))

        # ~release after release_time: the script let it go already, nothing is ended.
        r = self.sim.release("gripper")
        self.assertFalse(r.success, r.message)
        self.assertIn("already released", r.message)
        self.assertEqual(self.grasp(), (False, "scripted"))


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "scripted_release", ScriptedRelease)
