#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages; another python3 earlier
# on PATH may not.)
"""Behaviour 1: outputs at their rates, consistent stamps, finite values (frames_rates.test)."""
import math
import time
import unittest

import numpy as np
import rospy
import rostest
from visualization_msgs.msg import Marker, MarkerArray

import corde_rostest as ct

RECORD = 3.0  # s of wall time recorded after the outputs started
N = 10        # segments of the rope in test/ros/scenes/rope.yaml
RATES = {"tf": 50.0, "markers": 10.0, "state": 25.0}  # as set in frames_rates.test


class FramesRates(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("frames_rates_test")
        cls.sim = ct.Sim()
        cls.markers = ct.Recorder("/markers", MarkerArray)
        # Start counting once every output flows (subscriptions take a moment to connect).
        assert cls.sim.state.last() is not None, "no rod_state"
        assert cls.markers.last() is not None, "no markers"
        assert cls.sim.tf.last() is not None, "no tf"
        time.sleep(0.3)
        t0 = time.monotonic()
        time.sleep(RECORD)
        t1 = time.monotonic()
        cls.window = t1 - t0
        cls.states = [m for (t, m) in cls.sim.state.items if t0 <= t < t1]
        cls.tfs = [m for (t, m) in cls.sim.tf.items if t0 <= t < t1]
        cls.marker_msgs = [m for (t, m) in cls.markers.items if t0 <= t < t1]
        cls.all_states = cls.sim.state.messages()
        cls.all_tfs = cls.sim.tf.messages()
        cls.all_markers = cls.markers.messages()

    def check_rate(self, count, rate, what):
        measured = count / self.window
        # Lower bound generous for a loaded CI machine; the upper bound catches a default rate
        # (tf 50, markers 20, state 50 Hz) used instead of the configured one.
        self.assertGreater(measured, 0.7 * rate, "%s at %.1f Hz, configured %g" % (what, measured, rate))
        self.assertLess(measured, 1.15 * rate, "%s at %.1f Hz, configured %g" % (what, measured, rate))

    def test_rates(self):
        self.check_rate(len(self.tfs), RATES["tf"], "tf")
        self.check_rate(len(self.marker_msgs), RATES["markers"], "markers")
        self.check_rate(len(self.states), RATES["state"], "rod_state")

    def test_tf_has_every_frame_once_per_message_with_one_stamp(self):
        expected = {"rope", "rope/tip", "grasp/gripper"} | {"rope/seg_%d" % k for k in range(N)}
        for m in self.all_tfs:
            children = [t.child_frame_id for t in m.transforms]
            self.assertEqual(sorted(children), sorted(expected))
            self.assertEqual({t.header.frame_id for t in m.transforms}, {"world"})
            self.assertEqual(len({t.header.stamp for t in m.transforms}), 1)

    def test_stamps_monotonic(self):
        tf_stamps = [m.transforms[0].header.stamp.to_sec() for m in self.all_tfs]
        self.assertTrue(all(b > a for a, b in zip(tf_stamps, tf_stamps[1:])),
                        "tf stamps not strictly increasing")
        st = [m.header.stamp.to_sec() for m in self.all_states]
        self.assertTrue(all(b > a for a, b in zip(st, st[1:])), "rod_state stamps not increasing")
        sim = [m.sim_time for m in self.all_states]
        self.assertTrue(all(b > a for a, b in zip(sim, sim[1:])))
        mk = [m.markers[-1].header.stamp.to_sec() for m in self.all_markers]
        self.assertTrue(all(b > a for a, b in zip(mk, mk[1:])), "marker stamps not increasing")

    def test_state_stamp_is_when_the_state_was_due(self):
        # On wall time: stamp = epoch + simulation time, the ROS time the state was due; the
        # epoch moves only forward (when the node drops a backlog), never into the future.
        epochs = [m.header.stamp.to_sec() - m.sim_time for m in self.all_states]
        self.assertTrue(all(b > a - 1e-6 for a, b in zip(epochs, epochs[1:])), "epoch moved back")
        self.assertLessEqual(self.all_states[-1].header.stamp, rospy.get_rostime())
        self.assertEqual({m.header.frame_id for m in self.all_states}, {"world"})

    def test_real_time_factor_one(self):
        advanced = self.states[-1].sim_time - self.states[0].sim_time
        wall = self.window * (len(self.states) - 1) / len(self.states)
        self.assertAlmostEqual(advanced / wall, 1.0, delta=0.15)

    def test_tf_and_markers_show_the_state_of_their_stamp(self):
        by_stamp = {m.header.stamp: m for m in self.all_states}
        matched_tf = matched_markers = 0
        for m in self.all_tfs:
            s = by_stamp.get(m.transforms[0].header.stamp)
            if s is None:
                continue
            matched_tf += 1
            rod = s.rods[0]
            frames = {t.child_frame_id: t.transform for t in m.transforms}
            for k in range(N):
                p, r = ct.segment_pose(rod, k)
                tp, tr = ct.transform_pose(frames["rope/seg_%d" % k])
                np.testing.assert_allclose(tp, p, atol=1e-9)
                np.testing.assert_allclose(tr, r, atol=1e-9)
            tp, tr = ct.transform_pose(frames["rope"])  # the base: node 0, segment 0's rotation
            np.testing.assert_allclose(tp, ct.vec(rod.nodes[0]), atol=1e-9)
            np.testing.assert_allclose(tr, ct.quat_to_matrix(ct.quat(rod.orientations[0])), atol=1e-9)
            # Nothing moved the gripper: its frame is where the held end segment is.
            tp, tr = ct.transform_pose(frames["grasp/gripper"])
            p, r = ct.segment_pose(rod, N - 1)
            np.testing.assert_allclose(tp, p, atol=1e-6)
            np.testing.assert_allclose(tr, r, atol=1e-6)
        for m in self.all_markers:
            cyl = [k for k in m.markers if k.ns == "rope"]
            s = by_stamp.get(cyl[0].header.stamp) if cyl else None
            if s is None:
                continue
            matched_markers += 1
            for k in cyl:
                p, r = ct.segment_pose(s.rods[0], k.id)
                np.testing.assert_allclose(ct.vec(k.pose.position), p, atol=1e-9)
        # tf (50 Hz) and state (25 Hz) fall due together every other tf message.
        self.assertGreater(matched_tf, 10, "too few tf messages share a stamp with rod_state")
        self.assertGreater(matched_markers, 3)

    def test_markers_stable_ids(self):
        first = None
        for m in self.all_markers:
            adds = [(k.ns, k.id, k.type) for k in m.markers if k.action == Marker.ADD]
            if first is None:
                first = adds
            self.assertEqual(adds, first, "marker ids or types changed between messages")
            for k in m.markers:
                self.assertEqual(k.header.frame_id, "world")
        cyl = sorted(i for (ns, i, t) in first if ns == "rope" and t == Marker.CYLINDER)
        self.assertEqual(cyl, list(range(N)))
        self.assertEqual(len([1 for (ns, i, t) in first if ns == "grasps"]), 1)

    def test_nothing_non_finite(self):
        for s in self.all_states:
            self.assertTrue(ct.finite_state(s))
            self.assertEqual(len(s.rods), 1)
            self.assertEqual(len(s.rods[0].nodes), N + 1)
            self.assertEqual(len(s.rods[0].orientations), N)
        for m in self.all_tfs:
            self.assertTrue(ct.finite_tf(m))
        for m in self.all_markers:
            for k in m.markers:
                v = [k.pose.position.x, k.pose.position.y, k.pose.position.z, k.pose.orientation.x,
                     k.pose.orientation.y, k.pose.orientation.z, k.pose.orientation.w, k.scale.x,
                     k.scale.y, k.scale.z, k.color.r, k.color.g, k.color.b, k.color.a]
                self.assertTrue(all(math.isfinite(x) for x in v))


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "frames_rates", FramesRates)
