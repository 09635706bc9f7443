#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Behaviour 3: a gripper rotation about the rod tangent twists the rod (gripper_twist.test)."""
import math
import time
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import PoseStamped

import corde_rostest as ct

N = 10
THETA = 1.0  # rad about the tangent; well below the twist that buckles it (~4.5 rad)
# paper_rope: G = 0.5 MPa, r = 10 mm: C = G pi r^4 / 2. The twist runs from the ghost clamp at
# node 0 to the held segment's midpoint, 0.475 m.
C = 0.5e6 * math.pi * 0.01 ** 4 / 2
L_TWIST = 0.475
TANGENT = np.array([1.0, 0.0, 0.0])


class GripperTwist(unittest.TestCase):
    def test_rotation_about_tangent_twists_the_rod(self):
        rospy.init_node("gripper_twist_test")
        sim = ct.Sim()
        pub = rospy.Publisher("/grasps/gripper/pose", PoseStamped, queue_size=10)
        s0 = ct.wait_for_node(sim, self)
        rod0 = s0.rods[0]
        r_init = [ct.segment_pose(rod0, k)[1] for k in range(N)]
        p9, r9 = ct.segment_pose(rod0, N - 1)
        self.assertLess(rod0.elastic_energy, 1e-6)  # straight, untwisted, no gravity
        self.assertTrue(ct.wait_connected(pub))
        goal = ct.rot_x(THETA) @ r9
        end = time.monotonic() + 1.5
        while time.monotonic() < end:
            pub.publish(ct.pose_msg(p9, goal, "world"))
            time.sleep(0.05)
        # Average over 0.5 s: the torsional ringing (~10 Hz, damping ratio ~0.03) averages out.
        since = time.monotonic()
        time.sleep(0.5)
        states = sim.state.messages(since)
        self.assertGreater(len(states), 10)
        twist = np.mean([[ct.twist_about(ct.segment_pose(s.rods[0], k)[1], r_init[k], TANGENT)
                          for k in range(N)] for s in states], axis=0)
        energy = np.mean([s.rods[0].elastic_energy for s in states])
        for s in states:
            self.assertTrue(ct.finite_state(s))
        # The held segment turned with the gripper; the twist spreads linearly to the clamp.
        self.assertAlmostEqual(twist[N - 1], THETA, delta=0.01)
        self.assertTrue(all(b > a for a, b in zip(twist, twist[1:])), "twist %s" % twist)
        for k in range(N):
            expected = THETA * (0.025 + 0.05 * k) / L_TWIST
            self.assertAlmostEqual(twist[k], expected, delta=0.02 * THETA,
                                   msg="segment %d twist %.3f, expected %.3f" % (k, twist[k], expected))
        # Elastic energy rose to the twist energy C theta^2 / (2 L).
        expected_energy = C * THETA ** 2 / (2 * L_TWIST)
        self.assertGreater(energy, 0.95 * expected_energy, "energy %g J" % energy)
        self.assertLess(energy, 1.05 * expected_energy, "energy %g J" % energy)
        # Still straight: a pure twist, the centreline did not move.
        for i, p in enumerate(states[-1].rods[0].nodes):
            self.assertLess(np.linalg.norm(ct.vec(p) - ct.vec(rod0.nodes[i])), 2e-3)
        print("twist per segment %s, energy %.5g J (C theta^2 / 2L = %.5g J)" %
              (np.round(twist, 4), energy, expected_energy))


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "gripper_twist", GripperTwist)
