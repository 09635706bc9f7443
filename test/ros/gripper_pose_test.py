#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Behaviour 2: a gripper pose moves the held end segment there (gripper_pose.test)."""
import math
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import PoseStamped

import corde_rostest as ct

N = 10
POS_TOL = 1e-3   # m: the held segment follows its holder kinematically
ROT_TOL = 1e-2   # rad
TABLE_P = np.array([0.2, -0.1, 0.5])  # world -> table, a static transform
TABLE_R = ct.rot_z(math.pi / 2)


class GripperPose(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("gripper_pose_test")
        cls.sim = ct.Sim()
        cls.static = tf2_ros.StaticTransformBroadcaster()
        cls.static.sendTransform(ct.transform_msg("world", "table", TABLE_P, TABLE_R))
        cls.pub = rospy.Publisher("/grasps/gripper/pose", PoseStamped, queue_size=10)

    def drive_to(self, p, r, frame, seconds=1.5):
        """Publishes the pose at 20 Hz for `seconds`, then returns the latest tf message."""
        self.assertTrue(ct.wait_connected(self.pub))
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.pub.publish(ct.pose_msg(p, r, frame))
            time.sleep(0.05)
        time.sleep(0.1)
        return self.sim.tf.last(since=time.monotonic())

    def frame(self, tf_msg, child):
        for t in tf_msg.transforms:
            if t.child_frame_id == child:
                return ct.transform_pose(t.transform)
        self.fail("no frame %s" % child)

    def assert_pose(self, got, p, r, what):
        gp, gr = got
        self.assertLess(np.linalg.norm(gp - p), POS_TOL, "%s at %s, expected %s" % (what, gp, p))
        self.assertLess(ct.rotation_angle(gr @ r.T), ROT_TOL, what + " rotation")

    def test_1_world_frame(self):
        s0 = ct.wait_for_node(self.sim, self)
        p0, r0 = ct.segment_pose(s0.rods[0], N - 1)
        target = np.array([0.35, 0.1, 0.95])
        rot = ct.rot_z(-0.4) @ r0
        self.assertGreater(np.linalg.norm(target - p0), 0.1)  # a real move
        m = self.drive_to(target, rot, "world")
        self.assert_pose(self.frame(m, "rope/seg_%d" % (N - 1)), target, rot, "held segment")
        self.assert_pose(self.frame(m, "grasp/gripper"), target, rot, "grasp frame")
        # The rest of the rope hangs between the clamp and the gripper: still attached, finite.
        s = self.sim.fresh_state()
        self.assertTrue(ct.finite_state(s))
        self.assertLess(np.linalg.norm(ct.vec(s.rods[0].nodes[0]) - np.array([0, 0, 1])), 1e-9)

    def test_2_other_frame(self):
        s0 = ct.wait_for_node(self.sim, self)
        _, r0 = ct.segment_pose(s0.rods[0], N - 1)
        # The pose is given in 'table'; the node must transform it to 'world' with tf2.
        world_p = np.array([0.3, -0.15, 0.85])
        world_r = ct.rot_z(0.3) @ ct.rot_x(0.2) @ r0
        table_p = TABLE_R.T @ (world_p - TABLE_P)
        table_r = TABLE_R.T @ world_r
        m = self.drive_to(table_p, table_r, "table")
        self.assert_pose(self.frame(m, "rope/seg_%d" % (N - 1)), world_p, world_r, "held segment")
        self.assert_pose(self.frame(m, "grasp/gripper"), world_p, world_r, "grasp frame")


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "gripper_pose", GripperPose)
