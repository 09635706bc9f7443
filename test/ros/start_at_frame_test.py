#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""A scene grasp placed at a tf frame at start-up, hanging at rest from it (start_at_frame.test).

The node waits for the tool frame, which this test publishes on /tf_static only once it listens
to rod_state, so that it sees the first states the node publishes.
"""
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros

import corde_rostest as ct

POS_TOL = 1e-3  # m
ROT_TOL = 1e-2  # rad
# At rest: the largest node speed and kinetic energy in the first second (3e-13 m/s measured).
# Started straight along the tool frame's z (29 degrees off the vertical) instead of in
# equilibrium, the rope would swing down.
REST_SPEED = 1e-4  # m/s
REST_ENERGY = 1e-9  # J
TOOL_P = np.array([0.4, -0.2, 1.3])
TOOL_R = ct.rot_x(np.pi - 0.5)  # z (the held segment's tangent) down and to the side


class StartAtFrame(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("start_at_frame_test")
        cls.sim = ct.Sim()
        cls.static_br = tf2_ros.StaticTransformBroadcaster()

    def test_1_held_at_frame_at_rest(self):
        # Listening before the frame exists (the node waits for it): give the subscription time
        # to connect, then publish the tool frame.
        time.sleep(1.0)
        self.static_br.sendTransform(ct.transform_msg("world", "tool0", TOOL_P, TOOL_R))
        states = self.sim.state.wait(1, timeout=30.0)
        self.assertTrue(states, "no rod_state within 30 s of publishing the tool frame")
        first = states[0]
        p, r = ct.segment_pose(first.rods[0], 0)
        self.assertLess(np.linalg.norm(p - TOOL_P), POS_TOL,
                        "held segment at %s, tool frame at %s" % (p, TOOL_P))
        self.assertLess(ct.rotation_angle(r @ TOOL_R.T), ROT_TOL, "held segment's rotation")
        self.assertLess(first.sim_time, 0.05, "the first state seen is not the node's first")
        # Hanging: the free end below the tool frame.
        self.assertLess(ct.vec(first.rods[0].nodes[-1])[2], TOOL_P[2] - 0.3)
        # At rest for the first second of simulated time.
        self.sim.state.wait(1, timeout=30.0, pred=lambda m: m.sim_time >= 1.0)
        seen = [m for m in self.sim.state.messages() if m.sim_time <= 1.0]
        self.assertGreater(len(seen), 10)
        fastest = max(np.linalg.norm(ct.vec(v)) for m in seen for v in m.rods[0].velocities)
        self.assertLess(fastest, REST_SPEED, "the rope moves: a node at %.3g m/s" % fastest)
        energy = max(m.rods[0].kinetic_energy for m in seen)
        self.assertLess(energy, REST_ENERGY, "the rope moves: kinetic energy %.3g J" % energy)
        p, r = ct.segment_pose(seen[-1].rods[0], 0)
        self.assertLess(np.linalg.norm(p - TOOL_P), POS_TOL, "held segment after 1 s at %s" % p)

    def test_1b_reset_places_it_again(self):
        # The scene is read again (the rope straight down from (0, 0, 1)) and placed at the
        # frame's latest pose, without waiting.
        ct.wait_for_node(self.sim, self)
        r = self.sim.reset()
        self.assertTrue(r.success, r.message)
        time.sleep(0.3)  # (past states still in flight)
        s = self.sim.fresh_state()
        self.assertIsNotNone(s)
        p, rot = ct.segment_pose(s.rods[0], 0)
        self.assertLess(np.linalg.norm(p - TOOL_P), POS_TOL, "after ~reset at %s" % p)
        self.assertLess(ct.rotation_angle(rot @ TOOL_R.T), ROT_TOL, "rotation after ~reset")
        fastest = max(np.linalg.norm(ct.vec(v)) for v in s.rods[0].velocities)
        self.assertLess(fastest, REST_SPEED, "after ~reset a node moves at %.3g m/s" % fastest)

    def test_2_missing_frame_is_a_clear_error(self):
        scene = rospy.get_param("~scene")
        rospy.set_param("/no_frame/grasps", {"top": {
            "source": "tf", "frame": "no_such_tool", "start_at_frame": True,
            "start_timeout": 1.0}})
        p = ct.start_node("no_frame", ["_scene:=" + scene])
        try:
            out, _ = p.communicate(timeout=30.0)
        finally:
            ct.stop_node(p)
        self.assertNotEqual(p.returncode, 0, out)
        for w in ("cannot start", "~grasps/top/start_at_frame", "no_such_tool", "after 1 s"):
            self.assertIn(w, out, "the message does not say %s:\n%s" % (w, out))


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "start_at_frame", StartAtFrame)
