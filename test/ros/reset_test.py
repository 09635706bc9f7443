#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Behaviour 7: ~reset restores the initial state, the clock stays monotonic (reset.test)."""
import time
import unittest

import numpy as np
import rospy
import rostest

import corde_rostest as ct

H = 2.5e-4  # s


def initial_nodes(n):
    """rope.yaml and rope_coarse.yaml: straight from (0, 0, 1) along x, 0.5 m, n elements."""
    return [np.array([0.5 * i / n, 0.0, 1.0]) for i in range(n + 1)]


class Reset(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("reset_test")
        cls.sim = ct.Sim()
        assert cls.sim.state.last() is not None

    def assert_initial(self, s, n):
        rod = s.rods[0]
        self.assertEqual(len(rod.nodes), n + 1)
        for p, q in zip(rod.nodes, initial_nodes(n)):
            self.assertLess(np.linalg.norm(ct.vec(p) - q), 1e-12)
        for v in rod.velocities:
            self.assertEqual(np.linalg.norm(ct.vec(v)), 0.0)
        self.assertLess(rod.kinetic_energy, 1e-15)

    def assert_monotonic(self):
        st = self.sim.state.messages()
        stamps = [m.header.stamp.to_sec() for m in st]
        self.assertTrue(all(b >= a for a, b in zip(stamps, stamps[1:])), "rod_state stamp went back")
        sim = [m.sim_time for m in st]
        self.assertTrue(all(b >= a for a, b in zip(sim, sim[1:])), "sim_time went back")
        tf = [m.transforms[0].header.stamp.to_sec() for m in self.sim.tf.messages()]
        self.assertTrue(all(b > a for a, b in zip(tf, tf[1:])), "tf stamps not increasing")

    def test_1_reset_while_paused(self):
        time.sleep(0.5)  # the rope sags
        before = self.sim.paused_state()
        self.assertGreater(before.rods[0].kinetic_energy, 1e-6)
        r = self.sim.grasp("extra", arc_length=0.225)
        self.assertTrue(r.success, r.message)
        r = self.sim.configure(["time_step"], [1e-4])
        self.assertTrue(r.success, r.message)
        t = self.sim.fresh_state().sim_time
        r = self.sim.reset()
        self.assertTrue(r.success, r.message)
        s = self.sim.state_after(t + 0.5 * H)
        self.assertGreater(s.sim_time, t)  # the clock went on
        self.assert_initial(s, 10)
        self.assertEqual(s.time_step, H)  # the configured step is dropped with the scene
        # The run-time grasp is gone, the scene's gripper is back.
        # A tf message of the state after the reset: under load one from before it can still be
        # arriving (the state and tf subscribers are served in turn).
        m = self.sim.tf.last(pred=lambda m: m.transforms[0].header.stamp >= s.header.stamp)
        self.assertIsNotNone(m, "no tf after the reset")
        frames = {t.child_frame_id for t in m.transforms}
        self.assertIn("grasp/gripper", frames)
        self.assertNotIn("grasp/extra", frames)
        self.assertFalse(self.sim.release("extra").success)
        self.assert_monotonic()

    def test_2_reset_while_running(self):
        self.assertTrue(self.sim.pause(False).success)
        time.sleep(0.5)
        r = self.sim.reset()
        self.assertTrue(r.success, r.message)
        time.sleep(0.5)
        s = self.sim.fresh_state()
        self.assertTrue(ct.finite_state(s))
        self.assertFalse(s.paused)
        self.assert_monotonic()

    def test_3_bad_scene_changes_nothing(self):
        before = self.sim.paused_state()
        r = self.sim.reset("/nonexistent/scene.yaml")
        self.assertFalse(r.success)
        self.assertIn("nonexistent", r.message)
        s = self.sim.fresh_state()
        self.assertEqual(s.sim_time, before.sim_time)
        self.assertEqual(s.rods[0].nodes, before.rods[0].nodes)

    def test_4_reset_to_another_scene(self):
        # The states checked are the first after the reset's clock tick (a state published just
        # before the reset may still be in flight: once, the one after the 100 steps arrived
        # after the second reset, 3 mm sagged).
        other = rospy.get_param("~other_scene")
        t = self.sim.paused_state().sim_time
        r = self.sim.reset(other)
        self.assertTrue(r.success, r.message)
        self.assert_initial(self.sim.state_after(t + 0.5 * H), 5)
        t = self.sim.step(100).time
        # Empty: the current scene file, now the other one.
        r = self.sim.reset("")
        self.assertTrue(r.success, r.message)
        self.assert_initial(self.sim.state_after(t + 0.5 * H), 5)
        self.assert_monotonic()


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "reset", Reset)
