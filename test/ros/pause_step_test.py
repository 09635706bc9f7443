#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Behaviour 10: ~pause and ~step (pause_step.test)."""
import time
import unittest

import rospy
import rostest

import corde_rostest as ct

H = 2.5e-4  # s


class PauseStep(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("pause_step_test")
        cls.sim = ct.Sim()
        assert cls.sim.state.last() is not None

    def test_1_step_refused_while_running(self):
        r = self.sim.step(10)
        self.assertFalse(r.success)
        self.assertTrue(r.message)

    def test_2_paused_time_stands_still(self):
        r = self.sim.pause(True)
        self.assertTrue(r.success)
        self.assertIn("paused", r.message)
        self.assertTrue(self.sim.pause(True).success)  # pausing twice is harmless
        # (a state published just before the pause may still be in flight)
        first = self.sim.state.last(ct.WAIT, since=time.monotonic(), pred=lambda m: m.paused)
        since = time.monotonic()
        time.sleep(1.0)
        states = self.sim.state.messages(since)
        self.assertGreater(len(states), 35)  # still publishing at state_rate (50 Hz)
        for s in states:
            self.assertTrue(s.paused)
            self.assertEqual(s.sim_time, first.sim_time)
            self.assertEqual(s.steps, first.steps)
            self.assertEqual(s.header.stamp, first.header.stamp)
            self.assertEqual(s.rods[0].nodes, first.rods[0].nodes)
        # tf frames are sent once per stamp: silent while paused.
        self.assertEqual(self.sim.tf.messages(since + 0.1), [])

    def test_3_step_exactly(self):
        s0 = self.sim.fresh_state()
        t = s0.sim_time
        for n in [37, 1, 1, 250]:
            since = time.monotonic()
            r = self.sim.step(n)
            self.assertTrue(r.success, r.message)
            self.assertAlmostEqual(r.time, t + n * H, delta=1e-12)
            s = self.sim.state_after(r.time)
            self.assertEqual(s.sim_time, r.time)
            self.assertEqual(s.steps, s0.steps + n)
            # tf shows the stepped state once, stamped as in rod_state: the ROS time it was
            # computed at (on wall time), later than the state before and never in the future.
            m = self.sim.tf.last(since=since)
            self.assertIsNotNone(m)
            self.assertEqual(m.transforms[0].header.stamp, s.header.stamp)
            self.assertGreater(s.header.stamp, s0.header.stamp)
            self.assertLessEqual(s.header.stamp, rospy.get_rostime())
            t, s0 = r.time, s
        for n in [0, -5, 10000001]:
            r = self.sim.step(n)
            self.assertFalse(r.success, "steps %d" % n)
            self.assertAlmostEqual(r.time, t, delta=1e-12)
        self.assertEqual(self.sim.fresh_state().sim_time, t)

    def test_4_runs_again_at_real_time(self):
        r = self.sim.pause(False)
        self.assertTrue(r.success)
        self.assertIn("running", r.message)
        a = self.sim.fresh_state()
        wall0 = time.monotonic()
        time.sleep(1.5)
        b = self.sim.fresh_state()
        wall = time.monotonic() - wall0
        self.assertFalse(b.paused)
        # No backlog from the pause: simulation time follows wall time (factor 1).
        self.assertAlmostEqual((b.sim_time - a.sim_time) / wall, 1.0, delta=0.2)


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "pause_step", PauseStep)
