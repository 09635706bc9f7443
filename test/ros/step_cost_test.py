#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Issue 22, node part: configure requests whose steps are too slow are refused (step_cost.test)."""
import time
import unittest

import rospy
import rostest

import corde_rostest as ct


class StepCost(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("step_cost_test")
        cls.sim = ct.Sim()
        assert cls.sim.state.last() is not None

    def test_1_slow_configure_refused(self):
        s0 = self.sim.fresh_state()
        since = time.monotonic()
        r = self.sim.configure(["elements"], [100000], integrator="implicit_euler")
        took = time.monotonic() - since
        self.assertFalse(r.success, r.message)
        self.assertIn("100000", r.message)
        self.assertIn("per step", r.message)
        self.assertLess(took, 2.0)
        time.sleep(1.5)
        until = time.monotonic()
        for rec, name in [(self.sim.state, "rod_state"), (self.sim.tf, "tf")]:
            gap = rec.max_gap(since, until)
            self.assertLess(gap, 0.5, "%s silent for %.2f s" % (name, gap))
        s = self.sim.fresh_state()
        self.assertEqual(len(s.rods[0].nodes), len(s0.rods[0].nodes))
        since = time.monotonic()
        r = self.sim.reset()
        self.assertTrue(r.success, r.message)
        self.assertLess(time.monotonic() - since, 2.0)

    def test_2_moderate_configure_accepted(self):
        r = self.sim.configure(["elements"], [150])
        self.assertTrue(r.success, r.message)
        s = self.sim.fresh_state()
        self.assertEqual(len(s.rods[0].nodes), 151)
        self.assertTrue(self.sim.reset().success)


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "step_cost", StepCost)
