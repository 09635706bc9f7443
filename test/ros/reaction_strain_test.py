#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""The cable's pull on its holder and overstretching (reaction_strain.test)."""
import time
import unittest

import numpy as np
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, WrenchStamped

import corde_rostest as ct
from corde_sim.srv import ListGrasps

N = 10
MU = 1300 * np.pi * 0.01 ** 2   # kg/m: paper_rope, r = 1 cm
L = 0.5
G = 9.81


class ReactionStrain(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("reaction_strain_test")
        cls.sim = ct.Sim()
        cls.log = ct.RosoutRecorder("/sim")
        cls.reaction = ct.Recorder("/grasps/top/reaction", WrenchStamped)
        cls.diag = ct.Recorder("/diagnostics", DiagnosticArray)
        assert cls.sim.state.last() is not None

    def test_1_hanging_rope_pulls_with_its_weight(self):
        # Settled (1.5 s simulated), the rope pulls the holder down with its whole weight. The
        # holder frame is the top segment's frame (d3 pointing down), so the pull is +M g along z
        # of grasp/top; no torque about its origin (the rope hangs straight below it).
        self.sim.paused_state()
        self.addCleanup(self.sim.pause, False)
        self.assertTrue(self.sim.step(7500).success)
        # The wrench of these 500 steps may be published before ~step's answer arrives: count
        # from before the call (a wrench is only published for steps taken since the last one).
        time.sleep(0.6)  # the 7500 steps' wrench is out (state ticks run at 2 Hz or more)
        since = time.monotonic()
        r = self.sim.step(500)
        self.assertTrue(r.success)
        w = self.reaction.last(since=since)
        self.assertIsNotNone(w, "no reaction wrench")
        self.assertEqual(w.header.frame_id, "grasp/top")
        f = ct.vec(w.wrench.force)
        weight = MU * L * G
        # 1e-5: what is left of the settling after 1.6 s (the mean over the last 0.1 s).
        self.assertLess(np.linalg.norm(f - np.array([0, 0, weight])), 1e-5 * weight,
                        "reaction %s, weight %g N" % (f, weight))
        self.assertLess(np.linalg.norm(ct.vec(w.wrench.torque)), 1e-5 * weight * L)
        # Tension along the rope: the weight of what hangs below each segment's midpoint (the held
        # segment is rigid in the holder: no strain, no tension reported).
        s = self.sim.state_after(r.time)
        tension = np.array(s.rods[0].tension)
        below = MU * G * (L - (np.arange(N) + 0.5) * L / N)
        self.assertEqual(tension[0], 0.0)
        self.assertLess(np.max(np.abs(tension[1:] - below[1:])), 1e-5 * weight,
                        "%s vs %s" % (tension, below))
        self.assertGreater(s.rods[0].max_strain, 0.0)

    def test_2_overstretching_warns_and_slips(self):
        # A second grasp on the bottom segment pulled 0.3 m down stretches the rope by 60%, beyond
        # paper_rope's max_strain (10%): a warning, a WARN diagnostic, and the holder nearest the
        # most strained segment lets go (strain_action slip).
        r = self.sim.grasp("bottom", arc_length=0.475)
        self.assertTrue(r.success, r.message)
        pub = rospy.Publisher("/grasps/bottom/pose", PoseStamped, queue_size=10)
        self.assertTrue(ct.wait_connected(pub))
        s0 = self.sim.fresh_state()
        p, rot = ct.segment_pose(s0.rods[0], N - 1)
        since = time.monotonic()
        for _ in range(40):
            pub.publish(ct.pose_msg(p + np.array([0, 0, -0.3]), rot))
            time.sleep(0.05)
        time.sleep(0.5)
        self.assertTrue(self.log.lines(since, "above its material's max_strain"))
        self.assertTrue(self.log.lines(since, "slipped"))
        held = dict(zip(*[list(x) for x in (self.sim.service("list_grasps", ListGrasps)().names,
                                             self.sim.service("list_grasps", ListGrasps)().held)]))
        self.assertFalse(all(held.values()), "no holder slipped: %s" % held)
        warns = [st for m in self.diag.messages(since) for st in m.status
                 if st.level == 1 and "max_strain" in st.message]
        self.assertTrue(warns, "no WARN diagnostic about the strain")
        for s in self.sim.state.messages(since):
            self.assertTrue(ct.valid_state(s))

    def held(self):
        r = self.sim.service("list_grasps", ListGrasps)()
        return dict(zip(r.names, r.held))

    def test_3_a_slip_is_what_a_rollback_goes_back_to(self):
        # Single-stepped: the slip comes at the end of one ~step, an absurd force on the rope at
        # the start of the next, which blows up through every retry of the stability guard. The
        # node stops at its last good state: the one after the slip, with the slipped holder
        # still released (a rollback to before the slip would hold it again, the node having
        # said that it slipped).
        self.assertTrue(self.sim.reset().success)
        self.sim.paused_state()
        self.addCleanup(self.sim.reset)
        self.addCleanup(self.sim.pause, False)
        for name, s in [("bottom", 0.475), ("push", 0.225)]:
            r = self.sim.grasp(name, arc_length=s)
            self.assertTrue(r.success, r.message)
        # 'push' only carries the force below, on a free segment whichever holder slips. A
        # released ~grasp grasp is kept (with its topics) only while a wrench acts on it: a tiny
        # one is set before the release.
        pose_pub = rospy.Publisher("/grasps/bottom/pose", PoseStamped, queue_size=10)
        wrench_pub = rospy.Publisher("/grasps/push/wrench", WrenchStamped, queue_size=10)
        self.assertTrue(ct.wait_connected(pose_pub) and ct.wait_connected(wrench_pub))
        w = WrenchStamped()
        w.header.frame_id = "world"
        w.header.stamp = rospy.Time.now()
        w.wrench.force.z = 1e-9
        wrench_pub.publish(w)
        time.sleep(0.2)
        self.assertTrue(self.sim.step(1).success)  # applies the queued wrench
        r = self.sim.release("push")
        self.assertTrue(r.success, r.message)
        self.assertNotIn("topics end", r.message)
        p, rot = ct.segment_pose(self.sim.fresh_state().rods[0], N - 1)
        for _ in range(5):  # queued by the node for the next ~step
            pose_pub.publish(ct.pose_msg(p + np.array([0, 0, -0.3]), rot))
            time.sleep(0.1)
        r = self.sim.step(2500)  # 0.5 s: the holder glides 0.3 m down, the rope stretches 60%
        self.assertTrue(r.success, r.message)
        before = self.held()
        slipped = [g for g in ("top", "bottom") if not before[g]]
        self.assertEqual(len(slipped), 1, "one holder should have slipped: %s" % before)
        w = WrenchStamped()
        w.header.frame_id = "world"
        w.header.stamp = rospy.Time.now()
        w.wrench.force.z = 1e200
        for _ in range(5):
            wrench_pub.publish(w)
            time.sleep(0.1)
        r = self.sim.step(200)
        self.assertFalse(r.success, "the force should have stopped the simulation: " + r.message)
        self.assertIn("stopped at the last good state", r.message)
        after = self.held()
        self.assertEqual(after, before,
                         "grasp '%s' slipped, but the state the guard went back to holds it "
                         "again" % slipped[0])
        s = self.sim.fresh_state()
        self.assertTrue(ct.valid_state(s))


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "reaction_strain", ReactionStrain)
