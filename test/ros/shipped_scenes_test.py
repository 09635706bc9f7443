#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""The experiment scenes run in the node: keyframed clamps and grasps move as scripted, the
states stay valid (shipped_scenes.test)."""
import unittest

import numpy as np
import rospy
import rostest

import corde_rostest as ct

NAMES = ("helix", "plectoneme", "lift", "rope")


def stop_profile(u):
    """The 'stop' interpolation between two keyframes: 3u^2 - 2u^3, at rest at both."""
    u = min(max(u, 0.0), 1.0)
    return u * u * (3.0 - 2.0 * u)


class ShippedScenes(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("shipped_scenes_test")
        cls.sims = {ns: ct.Sim(ns="/" + ns, private_ns="/%s/sim" % ns) for ns in NAMES}

    def state_at(self, ns, t):
        s = self.sims[ns].state_after(t, timeout=60.0)
        self.assertIsNotNone(s, "%s: no rod_state at t >= %g s" % (ns, t))
        self.assertTrue(ct.valid_state(s), ns)
        return s

    def test_1_helix_clamp_moves_in_as_scripted(self):
        # The end clamp moves in by 3 along -z over 20 s (stop profile) while turning 27 times.
        s = self.state_at("helix", 1.5)
        z_end = ct.vec(s.rods[0].nodes[-1])[2]
        self.assertAlmostEqual(z_end, 100.0 - 3.0 * stop_profile(s.sim_time / 20.0), delta=1e-6)
        self.assertLess(z_end, 100.0 - 1e-3)

    def test_2_plectoneme_end_is_pulled_first(self):
        s = self.state_at("plectoneme", 2.0)
        x_end = ct.vec(s.rods[0].nodes[-1])[0]
        self.assertAlmostEqual(x_end, 1.002, delta=1e-6)

    def test_3_grasp_lifts_the_cable(self):
        # Keyframes (stop profile): lifted to z = 1.45 at 1 s, then carried to y = 0.6 by 3 s.
        s = self.state_at("lift", 1.3)
        self.assertLess(s.sim_time, 3.0)
        mid, _ = ct.segment_pose(s.rods[0], 20)
        y = 0.6 * stop_profile((s.sim_time - 1.0) / 2.0)
        np.testing.assert_allclose(mid, [0.5, y, 1.45], atol=1e-3)
        lowest = min(ct.vec(p)[2] for p in s.rods[0].nodes)
        self.assertGreater(lowest, 0.75)  # lifted clear of the table height it started at

    def test_4_rope_swings_down_in_air(self):
        # Released horizontally at z = 1.5 from a pin at z = 1.5: within 2.5 s (one and a half
        # swings) the tip passes well below the pin (1 m rope: 0.5 m at the bottom).
        self.state_at("rope", 2.5)
        tips = [ct.vec(m.rods[0].nodes[-1])[2] for m in self.sims["rope"].state.messages()
                if m.sim_time <= 2.5]
        self.assertLess(min(tips), 0.6)

if __name__ == "__main__":
    rostest.rosrun("corde_sim", "shipped_scenes", ShippedScenes)
