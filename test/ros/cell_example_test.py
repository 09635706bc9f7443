#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""The cell example (cell_example.test): after the start, the held segment sits in the gripper at
the tool frame (snap, offset identity) and the cable's other end lies on the table, none of it
inside the table."""
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros

import corde_rostest as ct

TOP = 0.75        # m, the table's top face (urdf/cell_example.urdf)
RADIUS = 0.003    # m, the cable's
SETTLE = 4.0      # s of simulation before the checks
HELD_TOL = 1e-3   # m: the held segment's midpoint from the tool frame's origin
SINK_TOL = 0.1 * RADIUS  # m: contact leaves at most this overlap with the table


class CellExample(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("cell_example_test")
        cls.sim = ct.Sim(private_ns="/corde_sim")
        cls.buffer = tf2_ros.Buffer(rospy.Duration(30.0))
        cls.listener = tf2_ros.TransformListener(cls.buffer)

    def test_cable_held_at_tool_and_lying_on_table(self):
        s = self.sim.state.last(timeout=60.0, pred=lambda m: m.sim_time > SETTLE)
        self.assertIsNotNone(s, "the simulation did not reach %g s" % SETTLE)
        rod = s.rods[0]
        tool = self.buffer.lookup_transform("world", "tool", rospy.Time(0), rospy.Duration(10.0))
        tool_p, tool_r = ct.transform_pose(tool.transform)
        mid, r = ct.segment_pose(rod, 0)
        self.assertLess(np.linalg.norm(mid - tool_p), HELD_TOL,
                        "held segment at %s, tool at %s" % (mid, tool_p))
        # The cable leaves the fingers along the tool's z (down): d3 of the held segment.
        self.assertGreater(float(r[:, 2] @ tool_r[:, 2]), 0.999)
        nodes = np.array([ct.vec(p) for p in rod.nodes])
        self.assertGreater(nodes[:, 2].min(), TOP + RADIUS - SINK_TOL,
                           "the cable is in the table: lowest node z %.5f" % nodes[:, 2].min())
        lying = int(np.sum(nodes[:, 2] < TOP + RADIUS + 1e-3))
        self.assertGreater(lying, len(nodes) // 2, "only %d nodes lie on the table" % lying)
        for m in self.sim.state.messages():
            self.assertTrue(ct.valid_state(m))


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "cell_example", CellExample)
