#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Behaviour 3b: smooth following between pose messages at 10 Hz and ~1000 Hz (gripper_rates.test).

The gripper moves at a constant 0.1 m/s, 0.2 m towards the clamp, then back. Between two
rod_state messages (50 Hz) the held segment must move at about that speed: jumping to each pose
would show at 10 Hz as intervals without motion and intervals at 5 times the speed. (Sideways, two
sweeps of 0.2 m would stretch the rope beyond paper_rope's max_strain, 10 %, where the holder
stalls: issue 24, item 4.)"""
import time
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import PoseStamped

import corde_rostest as ct

N = 10
SPEED = 0.1  # m/s along x


class GripperRates(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("gripper_rates_test")
        cls.sim = ct.Sim()
        cls.pub = rospy.Publisher("/grasps/gripper/pose", PoseStamped, queue_size=100)
        s = cls.sim.state.last()
        assert s is not None
        cls.p0, cls.r0 = ct.segment_pose(s.rods[0], N - 1)

    def sweep(self, rate, direction, seconds=2.0):
        """Moves the gripper from its current place along `direction` (unit) at SPEED, publishing
        at `rate`; returns the speeds of the held segment between consecutive states (after
        0.5 s)."""
        self.assertTrue(ct.wait_connected(self.pub))
        start = self.sim.fresh_state()
        p_start, _ = ct.segment_pose(start.rods[0], N - 1)
        t0 = time.monotonic()
        period = 1.0 / rate
        next_t = t0
        while True:
            now = time.monotonic()
            if now - t0 > seconds:
                break
            p = p_start + SPEED * (now - t0) * np.asarray(direction, float)
            self.pub.publish(ct.pose_msg(p, self.r0))
            next_t += period
            time.sleep(max(0.0, next_t - time.monotonic()))
        states = [m for m in self.sim.state.messages(t0 + 0.5) if m.sim_time > 0]
        states = [s for s in states if s.header.stamp.to_sec() > 0][: int(40 * (seconds - 0.6))]
        speeds = []
        for a, b in zip(states, states[1:]):
            dt = b.sim_time - a.sim_time
            if dt < 0.01:
                continue
            pa, _ = ct.segment_pose(a.rods[0], N - 1)
            pb, _ = ct.segment_pose(b.rods[0], N - 1)
            speeds.append(np.linalg.norm(pb - pa) / dt)
        return np.array(speeds)

    def check(self, rate, direction):
        v = self.sweep(rate, direction)
        self.assertGreater(len(v), 40, "too few states")
        inside = np.mean((v > 0.5 * SPEED) & (v < 1.6 * SPEED))
        print("rate %g Hz: %d intervals, speed median %.4f, min %.4f, max %.4f m/s, %.0f%% within "
              "0.5-1.6 x" % (rate, len(v), np.median(v), v.min(), v.max(), 100 * inside))
        self.assertAlmostEqual(np.median(v), SPEED, delta=0.2 * SPEED)
        self.assertGreater(inside, 0.9, "held segment moves in jerks: %s" % np.round(v, 3))

    def test_1_slow_gripper_10_hz(self):
        self.check(10.0, [-1.0, 0.0, 0.0])  # towards the clamp

    def test_2_fast_gripper_1000_hz(self):
        self.check(1000.0, [1.0, 0.0, 0.0])  # back


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "gripper_rates", GripperRates)
