#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Behaviour 6: twist-rate and torque commands twist the rod (torque_twist_rate.test)."""
import math
import time
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import WrenchStamped
from std_msgs.msg import Float64

import corde_rostest as ct

N = 10
H = 2.5e-4  # s, the scene's time step
C = 0.5e6 * math.pi * 0.01 ** 4 / 2  # twist stiffness of paper_rope (G = 0.5 MPa, r = 10 mm)
L_TWIST = 0.475  # m from the ghost clamp at node 0 to the end segment's midpoint
TANGENT = np.array([1.0, 0.0, 0.0])


class TorqueTwistRate(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("torque_twist_rate_test")
        cls.sim = ct.Sim()
        cls.rate_pub = rospy.Publisher("/grasps/gripper/twist_rate", Float64, queue_size=1,
                                       latch=True)
        cls.wrench_pub = rospy.Publisher("/grasps/gripper/wrench", WrenchStamped, queue_size=1,
                                         latch=True)

    def setUp(self):
        ct.wait_for_node(self.sim, self)
        self.assertTrue(self.sim.pause(True).success)
        r = self.sim.reset()
        self.assertTrue(r.success, r.message)
        self.s0 = self.sim.fresh_state()
        self.r_init = ct.segment_pose(self.s0.rods[0], N - 1)[1]

    def end_twist(self, s):
        return ct.twist_about(ct.segment_pose(s.rods[0], N - 1)[1], self.r_init, TANGENT)

    def step(self, n):
        r = self.sim.step(n)
        self.assertTrue(r.success, r.message)
        return self.sim.state_after(r.time)

    def test_twist_rate(self):
        rate = 2.0  # rad/s
        self.assertTrue(ct.wait_connected(self.rate_pub))
        self.rate_pub.publish(Float64(rate))
        time.sleep(0.3)  # delivered before the steps (callbacks are served while paused)
        s = self.step(400)
        # The held segment turned by rate * steps * h about its own tangent, exactly.
        self.assertAlmostEqual(self.end_twist(s), rate * 400 * H, delta=1e-6)
        w = ct.vec(s.rods[0].angular_velocities[N - 1])
        self.assertAlmostEqual(float(np.dot(w, TANGENT)), rate, delta=1e-3)
        self.assertGreater(s.rods[0].elastic_energy, self.s0.rods[0].elastic_energy + 1e-4)
        # Rate 0 stops it where it is.
        self.rate_pub.publish(Float64(0.0))
        time.sleep(0.3)
        before = self.end_twist(s)
        s = self.step(400)
        self.assertAlmostEqual(self.end_twist(s), before, delta=1e-9)

    def test_torque_on_released_end(self):
        r = self.sim.release("gripper")
        self.assertTrue(r.success, r.message)
        tau = 0.005  # N m about the tangent
        self.assertTrue(ct.wait_connected(self.wrench_pub))
        w = WrenchStamped()
        w.header.frame_id = "world"
        w.header.stamp = rospy.Time.now()
        w.wrench.torque.x = tau
        self.wrench_pub.publish(w)
        time.sleep(0.3)
        self.step(4000)  # 1 s: the torsional ringing (~10 Hz) has mostly decayed
        samples = []
        for _ in range(40):  # 1 s more, sampled every 25 ms, averaged
            s = self.step(100)
            self.assertTrue(ct.finite_state(s))
            samples.append(self.end_twist(s))
        # Static twist of a rod clamped at one end under an end torque: tau L / C.
        expected = tau * L_TWIST / C
        mean = float(np.mean(samples))
        self.assertAlmostEqual(mean, expected, delta=0.03 * expected,
                               msg="end twist %.4f rad, expected %.4f" % (mean, expected))
        print("end twist under torque %.5f rad (tau L / C = %.5f rad)" % (mean, expected))
        # Wrench back to zero: the rod untwists (mean about 0 once the ringing decays).
        w.header.stamp = rospy.Time.now()
        w.wrench.torque.x = 0.0
        self.wrench_pub.publish(w)
        time.sleep(0.3)
        self.step(4000)
        samples = [self.end_twist(self.step(100)) for _ in range(40)]
        self.assertLess(abs(float(np.mean(samples))), 0.1 * expected)


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "torque_twist_rate", TorqueTwistRate)
