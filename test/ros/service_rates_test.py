#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Issue 23: outputs keep their rate during ~step and ~reset (service_rates.test)."""
import time
import unittest

import rospy
import rostest

import corde_rostest as ct

H = 2.5e-4  # s, rope.yaml's step
PERIOD = 1.0 / 25.0  # s, state_rate and tf_rate of the launch file
STEPS = 1000000
ROPE = "test/ros/scenes/rope.yaml"
SLOW = "test/ros/scenes/slow_load.yaml"  # statics of 400 elements at load


class ServiceRates(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("service_rates_test")
        cls.sim = ct.Sim()
        assert cls.sim.state.last() is not None

    def assert_rates(self, what, since, until):
        for name, rec in [("rod_state", self.sim.state), ("/tf", self.sim.tf)]:
            gap = rec.max_gap(since, until)
            print("%s: %s largest gap %.3f s = %.2f periods over %.2f s" %
                  (what, name, gap, gap / PERIOD, until - since))
            self.assertLessEqual(gap, 2.0 * PERIOD,
                                 "%s: %s silent for %.3f s (%.1f periods)" %
                                 (what, name, gap, gap / PERIOD))

    def test_1_long_step(self):
        s0 = self.sim.paused_state()
        end = s0.steps + STEPS
        since = time.monotonic()
        r = self.sim.step(STEPS)
        self.assertTrue(r.success, r.message)
        done = self.sim.state.wait(1, timeout=60.0, pred=lambda m: m.steps >= end)
        self.assertTrue(done, "the %d steps did not end within 60 s" % STEPS)
        # Until the last state before the steps ended: tf is silent once they have (paused).
        until = max(t for (t, m) in self.sim.state.items if m.steps < end)
        print("~step %d: %.2f s" % (STEPS, until - since))
        self.assert_rates("~step %d" % STEPS, since, until)
        self.assertTrue(self.sim.pause(False).success)

    def test_2_reset(self):
        self.assertTrue(self.sim.pause(False).success)
        self.sim.fresh_state()
        since = time.monotonic()
        r = self.sim.reset(SLOW)
        until = time.monotonic()
        self.assertTrue(r.success, r.message)
        self.assertIn(SLOW, r.message)
        self.assert_rates("~reset to %s (%.2f s)" % (SLOW, until - since), since, until)
        # Back to the small scene (its 10 ms steps of 1500 elements are what the outputs wait
        # for while it runs, not the reset).
        r = self.sim.reset(ROPE)
        self.assertTrue(r.success, r.message)


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "service_rates", ServiceRates)
