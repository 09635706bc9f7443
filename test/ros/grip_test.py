#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""A friction grasp's grip force at run time, and its slip velocity (grip.test).

The cable of friction_hang.yaml (weight 0.333 N) hangs from 'gripper' (mu 0.5, 2 N: holds up to
1 N). Bad grip values on the topic and the service change nothing; a grip of 0.6 N (mu N = 0.3 N,
below the weight) lets it slide down at about g / 10, published on grasps/gripper/slip; 2 N again
stops it.
"""
import math
import time
import unittest

import rospy
import rostest
from std_msgs.msg import Float64

import corde_rostest as ct
from corde_sim.srv import ListGrasps, SetGrip

STEPS = 200  # 0.2 s of the scene's 1 ms steps


class Grip(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("grip_test")
        cls.sim = ct.Sim()
        cls.grip_pub = rospy.Publisher("/grasps/gripper/grip", Float64, queue_size=10)
        cls.slip = ct.Recorder("/grasps/gripper/slip", Float64)

    def set_grip(self, name, force):
        return self.sim.service("set_grip", SetGrip)(name, force)

    def top_z(self):
        """The cable's top node height after STEPS more steps (paused)."""
        r = self.sim.step(STEPS)
        self.assertTrue(r.success, r.message)
        s = self.sim.state_after(r.time - 1e-9)
        self.assertIsNotNone(s, "no rod_state after ~step")
        cable = [rod for rod in s.rods if rod.name == "cable"][0]
        return ct.vec(cable.nodes[0])[2]

    def held(self, name="gripper"):
        r = self.sim.service("list_grasps", ListGrasps)()
        return r.held[r.names.index(name)]

    def test_1_bad_values_change_nothing(self):
        ct.wait_for_node(self.sim, self)
        z0 = self.top_z()  # settled on its grip (holds: 1 N > 0.333 N)
        for name, force, says in (("gripper", math.nan, "finite"),
                                  ("gripper", -1.0, ">= 0"),
                                  ("gripper", math.inf, "finite"),
                                  ("gripper", 1e7, "at most"),
                                  ("nope", 1.0, "no grasp named 'nope'"),
                                  ("clamp", 1.0, "not by friction")):
            r = self.set_grip(name, force)
            self.assertFalse(r.success, "%s %g accepted" % (name, force))
            self.assertIn(says, r.message)
            self.assertIn("grip unchanged", r.message)
        self.assertTrue(ct.wait_connected(self.grip_pub))
        for force in (math.nan, -1.0, -math.inf):
            self.grip_pub.publish(Float64(force))
        time.sleep(0.5)
        z1 = self.top_z()
        self.assertLess(abs(z1 - z0), 1e-4, "the cable moved: top from %.5f to %.5f m" % (z0, z1))
        self.assertTrue(self.held())

    def test_2_low_grip_slides_high_grip_holds(self):
        ct.wait_for_node(self.sim, self)
        z0 = self.top_z()
        # The topic: 0.6 N, mu N = 0.3 N below the weight: the cable slides down.
        self.grip_pub.publish(Float64(0.6))
        time.sleep(0.5)
        since = time.monotonic()
        z1 = self.top_z()
        # From rest at (g - 0.3 N / m) = 0.96 m/s^2 for 0.2 s: about 19 mm.
        self.assertLess(z1, z0 - 0.01, "not sliding: top from %.5f to %.5f m" % (z0, z1))
        slips = [m.data for m in self.slip.wait(1, timeout=5.0, since=since)]
        self.assertTrue(slips, "no slip velocity published")
        time.sleep(0.5)
        slips = [m.data for m in self.slip.messages(since)]
        self.assertGreater(max(abs(v) for v in slips), 0.05, "slip velocities %s" % slips)
        # The service: 2 N again (1 N > weight): the slip stops within a few ms, then it holds.
        r = self.set_grip("gripper", 2.0)
        self.assertTrue(r.success, r.message)
        self.assertIn("1 N", r.message)
        self.top_z()
        z2 = self.top_z()
        z3 = self.top_z()
        self.assertLess(abs(z3 - z2), 1e-4, "still sliding: top from %.5f to %.5f m" % (z2, z3))
        self.assertTrue(self.held())


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "grip", Grip)
