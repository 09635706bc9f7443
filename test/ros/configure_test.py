#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Behaviour 8: ~configure, good and bad values (configure.test)."""
import math
import time
import unittest

import numpy as np
import rospy
import rostest

import corde_rostest as ct
from corde_sim.srv import ListGrasps

H = 2.5e-4  # s
NAN, INF = float("nan"), float("inf")

# (keys, values, rod, flags, flag_values, what the reply must mention)
BAD = [
    (["E"], [-1.0], "", [], [], "E"),
    (["E"], [0.0], "", [], [], "E"),
    (["E"], [NAN], "", [], [], "E"),
    (["E"], [INF], "", [], [], "E"),
    (["E"], [1.001e30], "", [], [], "valid: (0, 1e+30] Pa"),  # the scene reader's range
    (["G"], [-5.0], "", [], [], "G"),
    (["E_s"], [0.0], "", [], [], "E_s"),
    (["rho"], [0.0], "", [], [], "rho"),
    (["rho"], [1e9], "", [], [], "rho"),
    (["kappa"], [-1.0], "", [], [], "kappa"),
    (["gamma_t"], [-1.0], "", [], [], "gamma_t"),
    (["gamma_r"], [NAN], "", [], [], "gamma_r"),
    (["radius"], [0.0], "", [], [], "radius"),
    (["radius"], [2e4], "", [], [], "radius"),
    (["elements"], [0.0], "", [], [], "elements"),
    (["elements"], [-3.0], "", [], [], "elements"),
    (["elements"], [2.5], "", [], [], "elements"),
    (["elements"], [1e9], "", [], [], "elements"),
    (["time_step"], [0.0], "", [], [], "time_step"),
    (["time_step"], [-1e-4], "", [], [], "time_step"),
    (["time_step"], [1.0], "", [], [], "time_step"),
    (["time_step"], [NAN], "", [], [], "time_step"),
    (["time_step"], [5e-3], "", [], [], "time_step"),  # in range, but unstable for this rope
    (["gravity_z"], [1e6], "", [], [], "gravity_z"),
    (["damping_time"], [-1.0], "", [], [], "damping_time"),
    (["youngs_modulus"], [1e6], "", [], [], "youngs_modulus"),
    (["E"], [1e6], "cable", [], [], "cable"),
    (["E", "G"], [1e6], "", [], [], "differ"),
    (["E", "E"], [1e6, 2e6], "", [], [], "twice"),
    ([], [], "", ["magic"], [True], "magic"),
    ([], [], "", ["gravity"], [], "differ"),
    ([], [], "", [], [], "nothing"),
    (["E", "elements"], [1e6, 0.0], "", [], [], "elements"),  # a good value with a bad one
    (["E"], [1e6], "", ["gravity", "magic"], [False, True], "magic"),
]


class Configure(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("configure_test")
        cls.sim = ct.Sim()
        assert cls.sim.state.last() is not None
        time.sleep(0.3)  # the rope sags: bent, so E shows in its elastic energy
        cls.sim.paused_state()

    def step(self, n):
        r = self.sim.step(n)
        self.assertTrue(r.success, r.message)
        return self.sim.state_after(r.time)

    def test_1_bad_values_rejected_nothing_changed(self):
        before = self.sim.fresh_state()
        for keys, values, rod, flags, flag_values, mention in BAD:
            what = "%s=%s rod '%s' flags %s=%s" % (keys, values, rod, flags, flag_values)
            r = self.sim.configure(keys, values, rod, flags, flag_values)
            self.assertFalse(r.success, what)
            self.assertIn(mention, r.message, what)
        s = self.sim.fresh_state()
        self.assertEqual(s.sim_time, before.sim_time)
        self.assertEqual(s.time_step, before.time_step)
        self.assertEqual(s.rods[0].nodes, before.rods[0].nodes)
        self.assertEqual(s.rods[0].elastic_energy, before.rods[0].elastic_energy)  # E unchanged
        self.assertEqual(s.rods[0].kinetic_energy, before.rods[0].kinetic_energy)  # rho unchanged
        # The stepping is unchanged too: same step, same gravity, same material.
        r = self.sim.step(1)
        self.assertAlmostEqual(r.time - before.sim_time, H, delta=1e-12)

    def test_2_bending_modulus(self):
        before = self.sim.fresh_state()
        r = self.sim.configure(["E"], [2 * 0.5e6])  # paper_rope's E doubled
        self.assertTrue(r.success, r.message)
        s = self.sim.state_after(before.sim_time + 0.5 * H)
        self.assertEqual(s.rods[0].nodes, before.rods[0].nodes)  # same shape ...
        # Stiffer in bending: the elastic energy (stretch, bending, coupling) rises by the bending
        # part, which doubles.
        self.assertGreater(s.rods[0].elastic_energy, 1.05 * before.rods[0].elastic_energy)

    def test_3_time_step(self):
        r = self.sim.configure(["time_step"], [1e-4])
        self.assertTrue(r.success, r.message)
        s0 = self.sim.fresh_state()
        self.assertEqual(s0.time_step, 1e-4)
        s = self.step(10)
        self.assertAlmostEqual(s.sim_time - s0.sim_time, 10 * 1e-4, delta=1e-12)

    def test_4_gravity_flag(self):
        # A straight cantilever at rest (the gripper released): only gravity can move it.
        self.assertTrue(self.sim.reset().success)
        self.assertTrue(self.sim.release("gripper").success)
        r = self.sim.configure([], [], "", ["gravity"], [False])
        self.assertTrue(r.success, r.message)
        s0 = self.sim.fresh_state()
        s = self.step(400)
        for a, b in zip(s0.rods[0].nodes, s.rods[0].nodes):
            self.assertLess(np.linalg.norm(ct.vec(a) - ct.vec(b)), 1e-9)  # weightless: stays
        r = self.sim.configure(["gravity_z"], [-20.0], "", ["gravity"], [True])
        self.assertTrue(r.success, r.message)
        s = self.step(400)
        # In 0.1 s the free end drops by up to g t^2 / 2 = 0.1 m; more than 9.81 m/s^2 could do.
        drop = s0.rods[0].nodes[10].z - s.rods[0].nodes[10].z
        self.assertGreater(drop, 0.5 * 9.81 * 0.1 ** 2 + 0.005, "drop %g m" % drop)
        self.assertLess(drop, 0.5 * 20.0 * 0.1 ** 2 + 1e-3, "drop %g m" % drop)

    def test_5_elements_resample_keeps_shape(self):
        self.assertTrue(self.sim.reset().success)
        before = self.step(2000)  # 0.5 s of sagging
        # Twice the elements need a smaller step: refused (and nothing changed) without one.
        r = self.sim.configure(["elements"], [20], "rope")
        self.assertFalse(r.success)
        self.assertIn("time_step", r.message)
        self.assertEqual(len(self.sim.fresh_state().rods[0].nodes), 11)
        r = self.sim.configure(["elements", "time_step"], [20, 1e-4], "rope")
        self.assertTrue(r.success, r.message)
        s = self.sim.state_after(before.sim_time + 1e-9)  # the configure bumped the time by h
        old, new = before.rods[0], s.rods[0]
        self.assertEqual(len(new.nodes), 21)
        self.assertEqual(len(new.orientations), 20)
        # The same curve: every old node lies on the new one (old node i = new node 2 i).
        for i in range(11):
            self.assertLess(np.linalg.norm(ct.vec(old.nodes[i]) - ct.vec(new.nodes[2 * i])), 2e-3,
                            "node %d" % i)
        self.assertAlmostEqual(new.kinetic_energy, old.kinetic_energy,
                               delta=0.05 * old.kinetic_energy + 1e-9)
        # Still clamped, and the gripper (place: end) still holds the rope's end: the new last
        # segment (issue 24, item 5), which stays put.
        g = self.sim.service("list_grasps", ListGrasps)()
        held = list(g.segments)[list(g.names).index("gripper")]
        self.assertEqual(held, 19)
        s2 = self.step(400)
        self.assertLess(np.linalg.norm(ct.segment_pose(s2.rods[0], held)[0] -
                                       ct.segment_pose(new, held)[0]), 1e-9)
        self.assertLess(np.linalg.norm(ct.vec(s2.rods[0].nodes[0]) - np.array([0, 0, 1])), 1e-12)
        m = self.sim.tf.last(since=time.monotonic() - 0.1)
        frames = {t.child_frame_id for t in m.transforms}
        self.assertIn("rope/seg_19", frames)
        self.assertNotIn("rope/seg_20", frames)
        self.assertIn("grasp/gripper", frames)
        self.assertTrue(ct.finite_state(s2))

    def test_6_integrator_switch(self):
        self.assertTrue(self.sim.reset().success)
        before = self.sim.fresh_state()
        # An unknown name: refused with the list, nothing changed.
        r = self.sim.configure(integrator="rk4")
        self.assertFalse(r.success)
        self.assertIn("rk4", r.message)
        self.assertIn("implicit_euler", r.message)
        self.assertIn("bdf2", r.message)
        # 2 ms is beyond the explicit limit (3.7e-4 s): refused for split_rotation ...
        r = self.sim.configure(["time_step"], [2e-3])
        self.assertFalse(r.success)
        self.assertIn("implicit_euler", r.message)
        self.assertEqual(self.sim.fresh_state().time_step, before.time_step)
        # ... and taken with the implicit integrator, which then runs.
        r = self.sim.configure(["time_step"], [2e-3], integrator="implicit_euler")
        self.assertTrue(r.success, r.message)
        self.assertIn("integrator=implicit_euler", r.message)
        s0 = self.sim.fresh_state()
        self.assertEqual(s0.time_step, 2e-3)
        s = self.step(50)
        self.assertAlmostEqual(s.sim_time - s0.sim_time, 50 * 2e-3, delta=1e-9)
        self.assertTrue(ct.finite_state(s))
        # bdf2 (the second-order implicit method) at the same step: taken, and it runs.
        r = self.sim.configure(integrator="bdf2")
        self.assertTrue(r.success, r.message)
        self.assertIn("integrator=bdf2", r.message)
        s0 = self.sim.fresh_state()
        s = self.step(50)
        self.assertAlmostEqual(s.sim_time - s0.sim_time, 50 * 2e-3, delta=1e-9)
        self.assertTrue(ct.finite_state(s))
        # Back to the explicit method at 2 ms: refused, nothing changed; at its own step: taken.
        r = self.sim.configure(integrator="split_rotation")
        self.assertFalse(r.success)
        self.assertIn("time_step", r.message)
        self.assertEqual(self.sim.fresh_state().time_step, 2e-3)
        r = self.sim.configure(["time_step"], [H], integrator="split_rotation")
        self.assertTrue(r.success, r.message)
        s = self.step(10)
        self.assertTrue(ct.finite_state(s))


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "configure", Configure)
