#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""The time model following another node's /clock (time_external.test): a clock at 1000 s,
running at twice real time (as `rosbag play -r 2`), started before the node; the clock standing
still, jumping back and forward."""
import time
import unittest

import rospy
import rostest

import corde_rostest as ct
import time_clock as tc
from corde_sim.msg import WorldState

H = 2.5e-4  # s, the scene's step
# A state is published after its batch of steps, at most a loop period (5 ms) and an output's
# work after the clock it was stepped to: its stamp is this close behind the clock at the median
# (s of clock, which runs at RATE), never ahead; a loaded machine may delay a message's delivery
# up to MAX_DELAY.
RATE = 2.0
NEAR = 0.1
MAX_DELAY = 1.0


class TimeExternal(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("time_external_test")
        cls.clock = tc.ClockPublisher(1000.0, RATE)
        cls.states = tc.ClockRecorder("/rod_state", WorldState, cls.clock.now)
        cls.log = ct.RosoutRecorder("/sim")
        time.sleep(1.0)  # the clock runs before the node starts
        cls.node = tc.Node("sim", ["_scene:=" + rospy.get_param("~scene")])

    @classmethod
    def tearDownClass(cls):
        cls.node.stop()

    def check_in_step(self, items, what):
        tc.check_behind(self, items, what, NEAR, MAX_DELAY)

    def test_1_stamps_follow_the_clock_from_its_time(self):
        items = self.states.wait(1, ct.WAIT)
        self.assertTrue(items, "no rod_state within %g s\n%s" % (ct.WAIT, self.node.output()))
        since = time.monotonic()
        items = self.states.wait(40, 5.0, since)
        self.assertGreater(len(items), 30)
        self.check_in_step(items, "running")
        # Simulation time runs with the clock, one to one (not with wall time).
        (c0, m0), (c1, m1) = items[0], items[-1]
        self.assertAlmostEqual((m1.sim_time - m0.sim_time) / (c1 - c0), 1.0, delta=0.05)

    def test_2_a_clock_standing_still_stops_the_simulation(self):
        self.clock.pause()
        time.sleep(0.3)
        since = time.monotonic()
        items = self.states.wait(30, 3.0, since)
        self.assertGreater(len(items), 20)
        sims = [m.sim_time for _, m in items]
        self.assertLess(max(sims) - min(sims), 1.5 * H, "simulation time moved without /clock")
        self.check_in_step(items, "clock standing still")
        self.clock.resume()
        time.sleep(0.3)
        since = time.monotonic()
        items = self.states.wait(20, 3.0, since)
        self.assertGreater(items[-1][1].sim_time, max(sims) + 0.2)
        self.check_in_step(items, "clock going on")

    def test_3_a_clock_jumping_back_or_forward_reanchors(self):
        for jump, word in ((-500.0, "back"), (3600.0, "forward")):
            sim_before = self.states.wait(1, 1.0)[-1][1].sim_time
            log_since = time.monotonic()
            self.clock.jump(jump)
            time.sleep(0.3)
            since = time.monotonic()
            items = self.states.wait(20, 3.0, since)
            self.assertGreater(len(items), 10)
            self.check_in_step(items, "after a jump " + word)
            # The simulation went on from its state: no gap run, no time lost.
            self.assertLess(items[-1][1].sim_time - sim_before, 5.0)
            self.assertGreater(items[-1][1].sim_time, sim_before)
            lines = self.log.lines(log_since, "/clock jumped " + word)
            self.assertTrue(lines, "no warning about the jump " + word)


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "time_external", TimeExternal)
