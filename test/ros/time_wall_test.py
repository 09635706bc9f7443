#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""The time model on wall time (time_wall.test): stamps stay at ROS time when the node drops a
backlog it cannot keep up with, and are never in the future at real_time_factor 0, also after
~reset."""
import time
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray

import corde_rostest as ct
import time_clock as tc
from corde_sim.msg import WorldState

# A state is published after its batch, within a loop period and an output's work: its stamp
# is this close behind the ROS time it arrives at, at the median, never ahead; a loaded machine
# may delay a message's delivery up to MAX_DELAY.
NEAR = 0.05  # s
MAX_DELAY = 0.5  # s


def ros_now():
    return rospy.get_rostime().to_sec()


class TimeWall(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("time_wall_test")
        cls.slow = tc.ClockRecorder("/slow/rod_state", WorldState, ros_now)
        cls.fast = tc.ClockRecorder("/fast/rod_state", WorldState, ros_now)
        cls.diagnostics = ct.Recorder("/diagnostics", DiagnosticArray, queue_size=100)
        cls.fast_sim = ct.Sim("/fast", "/fast/sim")
        for r in (cls.slow, cls.fast):
            assert r.wait(1, ct.WAIT), "no rod_state within %g s" % ct.WAIT

    def check_at_ros_time(self, items, what):
        tc.check_behind(self, items, what, NEAR, MAX_DELAY)

    def test_backlog_dropped_stamps_stay_at_ros_time(self):
        time.sleep(1.0)
        since = time.monotonic()
        time.sleep(4.0)
        items = self.slow.since(since)
        self.assertGreater(len(items), 20)
        # It really is behind: simulation time runs far slower than ROS time.
        (r0, m0), (r1, m1) = items[0], items[-1]
        print("behind: simulation time per ROS second %.3f" % ((m1.sim_time - m0.sim_time) /
                                                             (r1 - r0)))
        self.assertLess((m1.sim_time - m0.sim_time) / (r1 - r0), 0.7)
        self.check_at_ros_time(items, "behind")
        said = [s.message for a in self.diagnostics.messages(since) for s in a.status
                if "backlog dropped" in s.message]
        self.assertTrue(said, "the diagnostics do not say that the node cannot keep up")

    def test_unpaced_never_stamps_in_the_future(self):
        since = time.monotonic()
        time.sleep(2.0)
        items = self.fast.since(since)
        self.assertGreater(len(items), 20)
        (r0, m0), (r1, m1) = items[0], items[-1]
        self.assertGreater((m1.sim_time - m0.sim_time) / (r1 - r0), 1.5)  # faster than real time
        self.check_at_ros_time(items, "factor 0")
        r = self.fast_sim.reset()
        self.assertTrue(r.success, r.message)
        since = time.monotonic()
        time.sleep(1.0)
        items = self.fast.since(since)
        self.assertGreater(len(items), 10)
        self.check_at_ros_time(items, "factor 0 after ~reset")


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "time_wall", TimeWall)
