#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Grasps a robot stack can lean on (grasp_safety.test). Each test is a defect found by trying
the node as a user: before the fix, each of them wedged or corrupted the node."""
import time
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import PoseStamped

import corde_rostest as ct
from corde_sim.srv import ListGrasps

N = 10
END = np.array([0.5, 0.0, 1.0])  # where the rope's held end starts


class GraspSafety(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("grasp_safety_test")
        cls.sim = ct.Sim()
        cls.log = ct.RosoutRecorder("/sim")
        cls.pub = rospy.Publisher("/grasps/gripper/pose", PoseStamped, queue_size=100)
        assert cls.sim.state.last() is not None

    def setUp(self):
        self.assertTrue(self.sim.reset().success)
        self.r0 = ct.segment_pose(self.sim.fresh_state().rods[0], N - 1)[1]
        self.assertTrue(ct.wait_connected(self.pub))

    def assert_all_valid(self, since, what):
        states = self.sim.state.messages(since)
        self.assertGreater(len(states), 10, what + ": rod_state went silent")
        for s in states:
            self.assertTrue(ct.valid_state(s), what + ": invalid state published")
        for m in self.sim.tf.messages(since):
            self.assertTrue(ct.valid_tf(m), what + ": invalid tf published")
        times = [s.sim_time for s in states]
        self.assertGreater(times[-1] - times[0], 0.3, what + ": simulation time stood still")
        self.assertFalse(self.log.lines(since, "restored the last good state"),
                         what + ": the state blew up")

    def list_grasps(self):
        return self.sim.service("list_grasps", ListGrasps)()

    def test_1_second_grasp_on_held_segment_refused(self):
        # The end segment (midpoint at 0.475 m) is held by 'gripper'.
        r = self.sim.grasp("other", arc_length=0.475)
        self.assertFalse(r.success)
        self.assertIn("already held by grasp 'gripper'", r.message)
        r = self.sim.grasp("other", arc_length=0.425)  # the neighbour shares node 9
        self.assertFalse(r.success)
        self.assertIn("shares node", r.message)
        r = self.sim.grasp("other", arc_length=0.3)
        self.assertTrue(r.success, r.message)
        g = self.list_grasps()
        self.assertEqual(sorted(g.names), ["gripper", "other"])
        self.assertEqual(list(g.held), [True, True])
        self.assertTrue(self.sim.release("other").success)
        # A released grasp made through ~grasp, without a wrench, is forgotten (issue 22).
        self.assertEqual(list(self.list_grasps().names), ["gripper"])

    def test_2_far_point_refused(self):
        r = self.sim.grasp("far", point=(5.0, 0.0, 1.0))
        self.assertFalse(r.success)
        self.assertIn("max_grasp_distance", r.message)
        r = self.sim.grasp("near", point=(0.2, 0.0, 0.99))
        self.assertTrue(r.success, r.message)
        self.assertTrue(self.sim.release("near").success)

    def test_3_absurd_pose_then_a_sane_one(self):
        # x = 1e6 once, then x = 0.4: the first is refused (outside the workspace), the second
        # moves the gripper; the node keeps running and publishing a valid state.
        since = time.monotonic()
        for _ in range(3):
            self.pub.publish(ct.pose_msg((1e6, 0, 1), self.r0))
            time.sleep(0.1)
        self.assertTrue(self.log.lines(since, "outside the workspace"))
        for _ in range(20):
            self.pub.publish(ct.pose_msg((0.4, 0, 1), self.r0))
            time.sleep(0.05)
        time.sleep(0.5)
        self.assert_all_valid(since, "absurd pose")
        p = ct.segment_pose(self.sim.fresh_state().rods[0], N - 1)[0]
        self.assertLess(np.linalg.norm(p - np.array([0.4, 0, 1])), 1e-3)

    def test_4_far_jump_is_limited(self):
        # A valid pose 4 m away: the holder goes there no faster than ~holder_max_speed (2 m/s)
        # instead of in one message interval, and the rope stays valid.
        since = time.monotonic()
        for _ in range(10):
            self.pub.publish(ct.pose_msg((4.5, 0, 1), self.r0))
            time.sleep(0.02)
        time.sleep(0.5)
        s = self.sim.fresh_state()
        v = np.linalg.norm(ct.vec(s.rods[0].velocities[N]))
        self.assertLess(v, 2.0 * 1.01)
        self.assertTrue(self.log.lines(since, "holder motion limited"))
        for _ in range(10):
            self.pub.publish(ct.pose_msg(END, self.r0))
            time.sleep(0.02)
        time.sleep(3.0)
        self.assert_all_valid(since, "far jump")
        for s in self.sim.state.messages(since):
            self.assertLess(np.linalg.norm(ct.vec(s.rods[0].velocities[N])), 2.0 * 1.01)
        # ~4 s of lagging there and back: one warning, not one every few seconds.
        self.assertEqual(len(self.log.lines(since, "holder motion limited")), 1)

    def test_5_streamed_offsets(self):
        # 5 cm offsets streamed as fast as python publishes (several kHz), then a 20 cm step
        # train at 100 Hz: bounded motion, never a blow-up.
        since = time.monotonic()
        end = time.monotonic() + 1.0
        k = 0
        while time.monotonic() < end:
            self.pub.publish(ct.pose_msg(END + np.array([0.05 * (k % 2), 0, 0]), self.r0))
            k += 1
        self.assertGreater(k, 1000)
        for j in range(200):
            self.pub.publish(ct.pose_msg(END + np.array([-0.2 * (j % 2), 0, 0]), self.r0))
            time.sleep(0.01)
        time.sleep(0.3)
        self.assert_all_valid(since, "streamed offsets")

    def test_6_service_burst_keeps_output_rates(self):
        # 2 s of ~reset and ~configure calls as fast as they go (hundreds per second): rod_state
        # (50 Hz) and tf (50 Hz) keep their rates.
        from corde_sim.srv import Configure, Reset
        reset = self.sim.service("reset", Reset)
        configure = self.sim.service("configure", Configure)
        time.sleep(0.5)
        since = time.monotonic()
        calls = 0
        while time.monotonic() < since + 2.0:
            if calls % 2:
                self.assertTrue(configure("", ["damping_time"], [1e-5 * (1 + calls % 3)], [], [],
                                          "").success)
            else:
                reset("")
            calls += 1
        self.assertGreater(calls, 50)
        burst_end = time.monotonic()
        # Before the fix each call pushed the next periodic publish one period later: outputs came
        # with the calls during the burst and went silent for 0.4-0.5 s after it. Watch 1 s more.
        time.sleep(1.0)
        window = time.monotonic() - since
        states = self.sim.state.messages(since)
        tfs = self.sim.tf.messages(since)
        self.assertGreater(len(states), 0.8 * 50 * window, "%d states in %g s" % (len(states), window))
        self.assertLess(len(states), 1.2 * 50 * window, "%d states in %g s" % (len(states), window))
        self.assertGreater(len(tfs), 0.8 * 50 * window, "%d tf messages in %g s" % (len(tfs), window))
        arrivals = [t for (t, m) in self.sim.state.items if t >= since]
        self.assertLess(max(np.diff(arrivals)), 0.25)
        self.assertGreater(arrivals[-1], burst_end + 0.9)


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "grasp_safety", GraspSafety)
