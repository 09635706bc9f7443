#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""A scene grasp moved by keyframes follows them, holds the last, and yields to a pose input
(scripted_grasp.test, scene test/ros/scenes/scripted.yaml)."""
import time
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import PoseStamped
from rosgraph_msgs.msg import Log

import corde_rostest as ct
from corde_sim.srv import ListGrasps

N = 10
POS_TOL = 1e-3  # m
ROT_TOL = 1e-2  # rad
# The scene's keyframes (displacements of the end segment's midpoint from its start) and the
# simulation times at which the grasp rests at each: after the lift (0.8 s) until the sideways
# move starts (1.2 s), and from the end of that move (2.0 s) on.
LIFT = np.array([-0.1, 0.0, 0.2])
SIDE = np.array([-0.1, 0.15, 0.2])
LIFT_WINDOW = (0.85, 1.2)
SIDE_FROM = 2.05
RUN_UNTIL = 2.6  # s of simulation time


class ScriptedGrasp(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("scripted_grasp_test")
        cls.sim = ct.Sim()
        cls.log = ct.RosoutRecorder("/sim")
        cls.pub = rospy.Publisher("/grasps/gripper/pose", PoseStamped, queue_size=10)

    def grasp_source(self):
        r = self.sim.service("list_grasps", ListGrasps)()
        self.assertEqual(list(r.names), ["gripper"])
        return r.sources[0]

    def assert_pose(self, got, p, r, what):
        gp, gr = got
        self.assertLess(np.linalg.norm(gp - p), POS_TOL, "%s at %s, expected %s" % (what, gp, p))
        self.assertLess(ct.rotation_angle(gr @ r.T), ROT_TOL, what + " rotation")

    def test_1_follows_keyframes(self):
        s0 = ct.wait_for_node(self.sim, self)
        self.assertTrue(s0.paused)
        self.assertLess(s0.sim_time, 1e-9)
        p0, r0 = ct.segment_pose(s0.rods[0], N - 1)
        self.sim.tf.clear()
        self.assertTrue(self.sim.pause(False).success)
        s = self.sim.state_after(RUN_UNTIL)
        self.assertIsNotNone(s, "simulation time did not reach %g s" % RUN_UNTIL)
        # Stamps are the ROS time at which a state was due: since the resume, that ROS time plus
        # simulation time.
        epoch = s.header.stamp.to_sec() - s.sim_time
        frames = ct.frames_in(self.sim.tf.messages(), "grasp/gripper")
        timed = [(t.header.stamp.to_sec() - epoch, ct.transform_pose(t.transform)) for t in frames]
        lift = [g for (t, g) in timed if LIFT_WINDOW[0] <= t <= LIFT_WINDOW[1]]
        side = [g for (t, g) in timed if t >= SIDE_FROM]
        moving = [(t, g) for (t, g) in timed if 0.2 <= t <= 0.6]
        self.assertGreater(len(lift), 3, "too few grasp frames while resting after the lift")
        self.assertGreater(len(side), 3, "too few grasp frames after the last keyframe")
        self.assertGreater(len(moving), 3, "too few grasp frames during the lift")
        for g in lift:
            self.assert_pose(g, p0 + LIFT, r0, "grasp after the lift")
        for g in side:
            self.assert_pose(g, p0 + SIDE, r0, "grasp after the last keyframe")
        # On the way up: between the start and the first keyframe, rising with time.
        zs = [g[0][2] for (t, g) in moving]
        self.assertTrue(p0[2] + 1e-3 < zs[0] and zs[-1] < p0[2] + LIFT[2] - 1e-3, zs)
        self.assertTrue(all(a <= b + 1e-9 for a, b in zip(zs, zs[1:])), zs)
        # The held segment is where its holder is (the grasp's offset is the identity).
        self.assert_pose(ct.segment_pose(s.rods[0], N - 1), p0 + SIDE, r0, "held segment")
        self.assertTrue(ct.valid_state(s))
        # No input has come: the keyframes still own the grasp.
        self.assertEqual(self.grasp_source(), "scripted")

    def test_2_pose_takes_over(self):
        self.assertTrue(self.sim.pause(False).success)  # (if test 1 stopped early)
        s0 = ct.wait_for_node(self.sim, self)
        p0, r0 = ct.segment_pose(s0.rods[0], N - 1)
        since = time.monotonic()
        # Near enough for the first pose's glide (0.1 s) to stay within the holder limits.
        target = np.array([0.35, 0.05, 1.15])
        rot = ct.rot_z(0.3) @ r0
        self.assertGreater(np.linalg.norm(target - p0), 0.1)  # a real move
        self.assertTrue(ct.wait_connected(self.pub))
        end = time.monotonic() + 1.5
        while time.monotonic() < end:
            self.pub.publish(ct.pose_msg(target, rot, "world"))
            time.sleep(0.05)
        time.sleep(0.1)
        m = self.sim.tf.last(since=time.monotonic())
        self.assertIsNotNone(m)
        grasp = [t for t in m.transforms if t.child_frame_id == "grasp/gripper"]
        self.assertEqual(len(grasp), 1)
        self.assert_pose(ct.transform_pose(grasp[0].transform), target, rot, "grasp frame")
        self.assertEqual(self.grasp_source(), "topic")
        # Said once, at INFO.
        logs = [m for m in self.log.messages(since) if m.name == "/sim" and "keyframes" in m.msg]
        self.assertEqual(len(logs), 1, [m.msg for m in logs])
        self.assertIn("gripper", logs[0].msg)
        self.assertEqual(logs[0].level, Log.INFO)

    def test_3_reset_starts_again(self):
        # Paused, so that the new world's time 0 is the published simulation time.
        self.sim.paused_state()
        r = self.sim.reset()
        self.assertTrue(r.success, r.message)
        s0 = self.sim.state.last(since=time.monotonic(), pred=lambda m: m.paused)
        self.assertIsNotNone(s0)
        p0, r0 = ct.segment_pose(s0.rods[0], N - 1)
        self.assertLess(np.linalg.norm(p0 - np.array([0.475, 0.0, 1.0])), 1e-9)
        self.assertEqual(self.grasp_source(), "scripted")
        self.assertTrue(self.sim.pause(False).success)
        s = self.sim.state_after(s0.sim_time + 1.0)
        self.assertIsNotNone(s)
        self.assertLess(s.sim_time - s0.sim_time, LIFT_WINDOW[1])
        self.assert_pose(ct.segment_pose(s.rods[0], N - 1), p0 + LIFT, r0, "held segment")


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "scripted_grasp", ScriptedGrasp)
