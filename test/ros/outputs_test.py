#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages; another python3 earlier
# on PATH may not.)
"""Tip and node frames, path and pose-array topics, clamp and legend markers (outputs.test).

Everything is compared at one paused state: the node is paused and stepped, and each output
stamped like that state must show it exactly.
"""
import math
import time
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import PoseArray
from nav_msgs.msg import Path
from visualization_msgs.msg import Marker, MarkerArray

import corde_rostest as ct

N = 10          # segments of the rope in test/ros/scenes/rope.yaml
RADIUS = 0.01   # m, paper_rope
REST = 0.05     # m, rest length of every segment (0.5 m straight rope)
FIXED = 5       # the node fixed by the override in outputs.test
# Segment 0's orientation when the scene was loaded (straight along x, d1 = z): the ghost frame.
GHOST = np.array([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])


def rel_vec(a, b):
    """Vector part of conj(a) b for (x, y, z, w) quaternions (the library's rel_vec)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array([aw * bx - ax * bw - ay * bz + az * by,
                     aw * by - ay * bw - az * bx + ax * bz,
                     aw * bz - az * bw - ax * by + ay * bx])


def largest_strain(rod):
    """The legend's scale: the largest per-segment surface strain r |u| (rest shape straight),
    segments taking the mean of their elements, floored at 1e-4 like the node."""
    q = [ct.quat(o) for o in rod.orientations]
    strain = np.zeros(len(q))
    for j in range(len(q) - 1):
        s = -2.0 if np.dot(q[j], q[j + 1]) < 0.0 else 2.0
        e = RADIUS * np.linalg.norm(s / REST * rel_vec(q[j], q[j + 1]))
        strain[j] += 0.5 * e
        strain[j + 1] += 0.5 * e
    strain[0] *= 2.0
    strain[-1] *= 2.0
    return max(1e-4, float(strain.max()))


def finite(values):
    return all(math.isfinite(v) for v in values)


def pose_values(p):
    return [p.position.x, p.position.y, p.position.z, p.orientation.x, p.orientation.y,
            p.orientation.z, p.orientation.w]


class Outputs(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("outputs_test")
        cls.sim = ct.Sim()
        cls.markers = ct.Recorder("/markers", MarkerArray)
        cls.paths = ct.Recorder("/rods/rope/path", Path)
        cls.poses = ct.Recorder("/rods/rope/poses", PoseArray)
        for rec, what in ((cls.sim.state, "rod_state"), (cls.sim.tf, "tf"),
                          (cls.markers, "markers"), (cls.paths, "rods/rope/path"),
                          (cls.poses, "rods/rope/poses")):
            assert rec.last() is not None, "no %s within %g s" % (what, ct.WAIT)
        time.sleep(0.3)  # let the rope sag a little: non-trivial strains and orientations
        cls.sim.paused_state()
        r = cls.sim.step(40)
        assert r.success, r.message
        # The state after the steps, then each output with its stamp (sent within a rate period;
        # markers, paths and poses are sent again at their rate while paused).
        cls.state = cls.sim.state.last(pred=lambda m: m.paused and abs(m.sim_time - r.time) < 1e-9)
        assert cls.state is not None, "no rod_state at t = %.6f" % r.time
        stamp = cls.state.header.stamp
        cls.tf = cls.sim.tf.last(pred=lambda m: m.transforms[0].header.stamp == stamp)
        cls.marker_msg = cls.markers.last(pred=lambda m: m.markers[-1].header.stamp == stamp)
        cls.path = cls.paths.last(pred=lambda m: m.header.stamp == stamp)
        cls.pose_array = cls.poses.last(pred=lambda m: m.header.stamp == stamp)
        cls.rod = cls.state.rods[0]

    def assert_pose(self, p, r, node=None, seg=None, what=""):
        """Position p at node `node` (or segment `seg`'s midpoint) with the rotation of segment
        min(node, N - 1) (or `seg`)."""
        if node is not None:
            want_p = ct.vec(self.rod.nodes[node])
            want_r = ct.quat_to_matrix(ct.quat(self.rod.orientations[min(node, N - 1)]))
        else:
            want_p, want_r = ct.segment_pose(self.rod, seg)
        np.testing.assert_allclose(p, want_p, atol=1e-9, err_msg=what)
        np.testing.assert_allclose(r, want_r, atol=1e-9, err_msg=what)

    def test_tip_and_node_frames(self):
        self.assertIsNotNone(self.tf, "no tf message stamped like the paused state")
        frames = {t.child_frame_id: t for t in self.tf.transforms}
        expected = ({"rope", "rope/tip", "grasp/gripper"} | {"rope/seg_%d" % k for k in range(N)}
                    | {"rope/node_%d" % i for i in range(N + 1)})
        self.assertEqual(sorted(frames), sorted(expected))
        self.assertEqual(len(self.tf.transforms), len(expected), "a frame sent twice")
        tp, tr = ct.transform_pose(frames["rope/tip"].transform)
        self.assert_pose(tp, tr, node=N, what="tip")
        for i in range(N + 1):
            tp, tr = ct.transform_pose(frames["rope/node_%d" % i].transform)
            self.assert_pose(tp, tr, node=i, what="node_%d" % i)
        for t in self.tf.transforms:
            self.assertEqual(t.header.frame_id, "world")
        self.assertTrue(ct.finite_tf(self.tf))

    def test_path_is_the_centreline(self):
        self.assertIsNotNone(self.path, "no rods/rope/path stamped like the paused state")
        self.assertEqual(self.path.header.frame_id, "world")
        self.assertEqual(len(self.path.poses), N + 1)
        for i, ps in enumerate(self.path.poses):
            self.assertEqual(ps.header.frame_id, "world")
            self.assertEqual(ps.header.stamp, self.state.header.stamp)
            self.assertTrue(finite(pose_values(ps.pose)))
            self.assert_pose(ct.vec(ps.pose.position),
                             ct.quat_to_matrix(ct.quat(ps.pose.orientation)), node=i,
                             what="path pose %d" % i)

    def test_pose_array_is_the_segment_frames(self):
        self.assertIsNotNone(self.pose_array, "no rods/rope/poses stamped like the paused state")
        self.assertEqual(self.pose_array.header.frame_id, "world")
        self.assertEqual(len(self.pose_array.poses), N)
        for k, p in enumerate(self.pose_array.poses):
            self.assertTrue(finite(pose_values(p)))
            self.assert_pose(ct.vec(p.position), ct.quat_to_matrix(ct.quat(p.orientation)), seg=k,
                             what="segment %d" % k)

    def test_clamp_markers(self):
        self.assertIsNotNone(self.marker_msg, "no markers stamped like the paused state")
        clamps = {m.id: m for m in self.marker_msg.markers if m.ns == "clamps"}
        # The ghost clamp's node 0 and the fixed node, each once; the id is the node.
        self.assertEqual(sorted(clamps), [0, FIXED])
        for i, m in clamps.items():
            self.assertEqual(m.type, Marker.CUBE)
            self.assertEqual(m.action, Marker.ADD)
            self.assertEqual(m.header.frame_id, "world")
            np.testing.assert_allclose(ct.vec(m.pose.position), ct.vec(self.rod.nodes[i]),
                                       atol=1e-9)
            # A few times the rod's radius, solid grey.
            for s in (m.scale.x, m.scale.y, m.scale.z):
                self.assertGreater(s, RADIUS)
                self.assertLess(s, 10 * RADIUS)
            self.assertAlmostEqual(m.color.r, m.color.g, delta=0.05)
            self.assertAlmostEqual(m.color.g, m.color.b, delta=0.05)
            self.assertEqual(m.color.a, 1.0)
        # The ghost clamp shows its fixed frame; the fixed node its segment's frame.
        r0 = ct.quat_to_matrix(ct.quat(clamps[0].pose.orientation))
        np.testing.assert_allclose(r0, GHOST, atol=1e-9)
        rf = ct.quat_to_matrix(ct.quat(clamps[FIXED].pose.orientation))
        np.testing.assert_allclose(rf, ct.quat_to_matrix(ct.quat(self.rod.orientations[FIXED])),
                                   atol=1e-9)
        # The same ids in every message (stable), at fixed nodes that do not move.
        for msg in self.markers.messages():
            ids = sorted(m.id for m in msg.markers if m.ns == "clamps")
            self.assertEqual(ids, [0, FIXED])

    def test_strain_legend(self):
        self.assertIsNotNone(self.marker_msg, "no markers stamped like the paused state")
        legend = [m for m in self.marker_msg.markers if m.ns == "legend"]
        self.assertEqual(len(legend), 1)
        m = legend[0]
        self.assertEqual((m.id, m.type), (0, Marker.TEXT_VIEW_FACING))
        prefix, suffix = "rope: blue 0 .. red ", " surface strain"
        self.assertTrue(m.text.startswith(prefix) and m.text.endswith(suffix), m.text)
        top = float(m.text[len(prefix):-len(suffix)])
        want = largest_strain(self.rod)
        self.assertAlmostEqual(top, want, delta=0.06 * want,
                               msg="legend '%s', largest strain %g" % (m.text, want))
        print("legend '%s', largest strain from rod_state %.4g" % (m.text, want))
        # Near the rod's start, above it.
        start = ct.vec(self.rod.nodes[0])
        pos = ct.vec(m.pose.position)
        self.assertLess(np.linalg.norm(pos - start), 0.3)
        self.assertGreater(pos[2], start[2])
        self.assertGreater(m.scale.z, 0.0)
        # The most strained segment is drawn in the scale's red.
        if want > 1.01e-4:
            cyl = [c for c in self.marker_msg.markers if c.ns == "rope"]
            self.assertTrue(any(c.color.r > 0.9 and c.color.g < 0.25 for c in cyl))

    def test_everything_finite(self):
        for msg in self.markers.messages():
            for k in msg.markers:
                v = pose_values(k.pose) + [k.scale.x, k.scale.y, k.scale.z, k.color.r, k.color.g,
                                           k.color.b, k.color.a]
                self.assertTrue(finite(v), "%s/%d" % (k.ns, k.id))
        for msg in self.paths.messages():
            self.assertTrue(all(finite(pose_values(p.pose)) for p in msg.poses))
        for msg in self.poses.messages():
            self.assertTrue(all(finite(pose_values(p)) for p in msg.poses))
        for msg in self.sim.tf.messages():
            self.assertTrue(ct.finite_tf(msg))


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "outputs", Outputs)
