#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Behaviour 11: /clock from the node, stamps = simulation time (clock.test)."""
import time
import unittest

import rospy
import rostest
from rosgraph_msgs.msg import Clock

import corde_rostest as ct

H = 2.5e-4  # s


class ClockTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("clock_test")
        cls.sim = ct.Sim()
        cls.clock = ct.Recorder("/clock", Clock, queue_size=1000)
        assert cls.sim.state.last() is not None

    def clocks(self, since=None):
        return [m.clock.to_sec() for m in self.clock.messages(since)]

    def test_1_clock_runs_with_the_simulation(self):
        since = time.monotonic()
        time.sleep(1.5)
        wall = time.monotonic() - since
        c = self.clocks(since)
        self.assertGreater(len(c), 30)
        self.assertTrue(all(b > a for a, b in zip(c, c[1:])), "/clock not strictly increasing")
        self.assertGreater(c[0], 0.0)
        self.assertAlmostEqual((c[-1] - c[0]) / wall, 1.0, delta=0.2)  # real_time_factor 1
        # This test node's ROS time is the node's clock.
        self.assertAlmostEqual(rospy.get_rostime().to_sec(), self.clocks()[-1], delta=0.1)

    def test_2_stamps_are_simulation_time(self):
        states = self.sim.state.messages()
        self.assertGreater(len(states), 10)
        for s in states:
            self.assertAlmostEqual(s.header.stamp.to_sec(), s.sim_time, delta=1e-6)
            self.assertGreater(s.header.stamp.to_sec(), 0.0)
        tf = [m.transforms[0].header.stamp.to_sec() for m in self.sim.tf.messages()]
        self.assertGreater(len(tf), 10)
        self.assertGreater(min(tf), 0.0)
        self.assertTrue(all(b > a for a, b in zip(tf, tf[1:])))
        # Every tf stamp is a time the clock showed (the state published in the same iteration).
        clocks = set(round(c, 9) for c in self.clocks())
        shown = sum(1 for t in tf if round(t, 9) in clocks)
        self.assertGreater(shown, 0.9 * len(tf))

    def test_3_pause_step_reset_keep_the_clock_monotonic(self):
        r = self.sim.pause(True)
        self.assertTrue(r.success)
        time.sleep(0.2)
        since = time.monotonic()
        time.sleep(0.5)
        self.assertEqual(self.clocks(since), [], "/clock moved while paused")
        last = self.clocks()[-1]
        r = self.sim.step(10)
        self.assertTrue(r.success, r.message)
        self.assertAlmostEqual(r.time, last + 10 * H, delta=1e-9)
        r = self.sim.reset()
        self.assertTrue(r.success, r.message)
        self.assertTrue(self.sim.pause(False).success)
        time.sleep(0.5)
        c = self.clocks()
        self.assertTrue(all(b > a for a, b in zip(c, c[1:])), "/clock went back")
        self.assertGreater(c[-1], last + 10 * H)


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "clock", ClockTest)
