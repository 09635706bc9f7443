#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Issue 24, item 3: pose streams followed by their stamps (pose_stream.test).

The gripper of test/ros/scenes/rope.yaml is sent round a circle of 5 cm radius at 0.157 m/s (one
turn in 2 s), across the rope, at 10, 50, 200 and 1000 Hz, one rate after the other, the circle's
phase going on. Each pose is computed for its stamp, so the stream is exact whenever the messages
leave; the held segment is measured on the node's own rod_state stamps, not on arrival times, so a
loaded machine delays the messages but does not change what is measured. After 0.5 s of each rate
the segment's midpoint must stay within 1 mm of the circle and move at its speed: the 90th
percentile of its speed between states within 30 % of 0.157 m/s (stop-and-go shows as
intervals at rest and intervals at twice the speed)."""
import math
import time
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import PoseStamped

import corde_rostest as ct

N = 10  # the held segment is N - 1 (place: end)
RADIUS = 0.05  # m
SPEED = 0.157  # m/s
OMEGA = SPEED / RADIUS  # rad/s
SECONDS = 2.5  # s of stream per rate
SETTLE = 0.5  # s at the start of each rate not measured


class PoseStream(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("pose_stream_test")
        cls.sim = ct.Sim()
        cls.pub = rospy.Publisher("/grasps/gripper/pose", PoseStamped, queue_size=1000)
        s = cls.sim.state.last()
        assert s is not None
        p0, cls.r0 = ct.segment_pose(s.rods[0], N - 1)
        # The circle across the rope (the y-z plane), through the segment's start position.
        cls.centre = p0 - np.array([0.0, RADIUS, 0.0])
        cls.phase = 0.0  # where the next rate starts on the circle (rad)

    def circle(self, phase):
        return self.centre + RADIUS * np.array([0.0, math.cos(phase), math.sin(phase)])

    def stream(self, rate):
        """Streams the circle at `rate` for SECONDS from the current phase; returns the states
        stamped within the measured part of the stream."""
        self.assertTrue(ct.wait_connected(self.pub))
        t0 = rospy.Time.now().to_sec() + 0.05
        count = int(round(SECONDS * rate))
        for k in range(count + 1):
            t = t0 + k / rate
            wait = t - rospy.Time.now().to_sec()
            if wait > 0:
                time.sleep(wait)
            p = self.circle(self.phase + OMEGA * (t - t0))
            self.pub.publish(ct.pose_msg(p, self.r0, stamp=rospy.Time.from_sec(t)))
        t_end = t0 + count / rate
        self.phase += OMEGA * (t_end - t0)
        # The node's states up to the stream's last stamp (the held segment follows a little late).
        self.sim.state.wait(1, pred=lambda m: m.header.stamp.to_sec() > t_end + 0.3)
        return [m for m in self.sim.state.messages()
                if t0 + SETTLE <= m.header.stamp.to_sec() <= t_end]

    def check(self, rate):
        states = self.stream(rate)
        self.assertGreater(len(states), 100, "too few states")
        points = [ct.segment_pose(m.rods[0], N - 1)[0] for m in states]
        stamps = np.array([m.header.stamp.to_sec() for m in states])
        # Distance from the circle: off its plane and off its radius within it.
        off = []
        for p in points:
            d = p - self.centre
            off.append(math.hypot(d[0], math.hypot(d[1], d[2]) - RADIUS))
        off = np.array(off)
        speeds = []
        for a, b, ta, tb in zip(points, points[1:], stamps, stamps[1:]):
            if tb - ta >= 0.001:
                speeds.append(np.linalg.norm(b - a) / (tb - ta))
        speeds = np.array(speeds)
        p90 = np.percentile(speeds, 90)
        print("rate %g Hz: %d states, off the circle max %.2f mm, median %.2f mm; speed median "
              "%.4f, p90 %.4f, p10 %.4f, max %.4f m/s" % (rate, len(states), 1e3 * off.max(),
                                                1e3 * np.median(off), np.median(speeds), p90,
                                                np.percentile(speeds, 10), speeds.max()))
        self.assertLess(off.max(), 1e-3, "the held segment leaves the circle by %.2f mm at %g Hz"
                        % (1e3 * off.max(), rate))
        self.assertLess(abs(p90 - SPEED), 0.3 * SPEED,
                        "stop-and-go at %g Hz: speed p90 %.3f m/s (median %.3f, p10 %.3f)"
                        % (rate, p90, np.median(speeds), np.percentile(speeds, 10)))
        self.assertGreater(np.percentile(speeds, 10), 0.7 * SPEED,
                           "stop-and-go at %g Hz: at rest in more than 10 %% of the intervals"
                           % rate)

    def test_1_rate_10_hz(self):
        self.check(10.0)

    def test_2_rate_50_hz(self):
        self.check(50.0)

    def test_3_rate_200_hz(self):
        self.check(200.0)

    def test_4_rate_1000_hz(self):
        self.check(1000.0)


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "pose_stream", PoseStream)
