#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy, rosbag and the generated messages.)
"""The time model under `rosbag play --clock` (time_rosbag.test): the node waits for the bag's
clock, stamps its states at the bag's time, and follows it back when the bag loops."""
import os
import shutil
import signal
import subprocess
import tempfile
import time
import unittest

import rosbag
import rospy
import rostest
from std_msgs.msg import String

import corde_rostest as ct
import time_clock as tc
from corde_sim.msg import WorldState

T0 = 1.7e9  # s, the bag's start
LENGTH = 2.5  # s of bag
# s: a stamp this close behind the clock at the median, never ahead (time_external_test.py)
NEAR = 0.05
MAX_DELAY = 0.5
CLOCK_PERIOD = 0.01  # s: rosbag play publishes /clock at 100 Hz


def write_bag(path):
    with rosbag.Bag(path, "w") as bag:
        for i in range(int(LENGTH * 100) + 1):
            bag.write("/time_rosbag/chatter", String(data="tick"), rospy.Time.from_sec(T0 + 0.01 * i))


class TimeRosbag(unittest.TestCase):
    def test_stamps_follow_the_bags_clock(self):
        rospy.init_node("time_rosbag_test")
        states = tc.ClockRecorder("/rod_state", WorldState, lambda: rospy.get_rostime().to_sec())
        log = ct.RosoutRecorder("/sim")
        rospy.wait_for_service("/sim/pause", timeout=ct.WAIT)  # the node is up
        time.sleep(0.5)
        self.assertEqual(states.since(0.0), [], "rod_state published before any /clock")
        folder = tempfile.mkdtemp(prefix="corde_time_rosbag_")
        try:
            bag = os.path.join(folder, "clock.bag")
            write_bag(bag)
            play = subprocess.Popen(["rosbag", "play", "--clock", "--loop", "-q", bag],
                                    stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                    stderr=subprocess.STDOUT, start_new_session=True)
            try:
                time.sleep(7.0)  # two loops and more
            finally:
                os.killpg(play.pid, signal.SIGINT)
                play.wait(10)
        finally:
            shutil.rmtree(folder)
        items = states.since(0.0)
        self.assertGreater(len(items), 100)
        # Split where the bag's clock went back (a new loop); the first 0.2 s of clock after
        # each jump back may still see a state stepped before it.
        checked = []
        start = items[0][0]
        for i, (clock, m) in enumerate(items):
            if i > 0 and clock < items[i - 1][0]:
                start = clock
            if clock >= start + 0.2:
                checked.append((clock, m))
        self.assertGreater(len(checked), 80)
        self.assertGreater(min(m.header.stamp.to_sec() for _, m in checked), T0 - 1.0)
        # (The node may get a /clock message before this test does: one message, 10 ms, ahead.)
        tc.check_behind(self, checked, "rosbag", NEAR, MAX_DELAY, ahead=CLOCK_PERIOD + 1e-3)
        self.assertTrue(log.lines(None, "/clock jumped back"), "no warning when the bag looped")


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "time_rosbag", TimeRosbag)
