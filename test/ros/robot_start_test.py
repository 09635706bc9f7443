#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Robot links that come to tf late (robot_start.test).

A cord lies 1 mm above the top of a robot's table link (test/ros/scenes/on_table.yaml,
test/ros/urdf/table.urdf). The test starts the node, and only 2 s later puts the table on tf:
the node must wait for it before stepping, so the cord never sinks into the table. A second node,
whose table never comes, starts after ~robot_start_timeout with a warning naming the link.
"""
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import TransformStamped
from rosgraph_msgs.msg import Log
from tf2_msgs.msg import TFMessage

from corde_rostest import Recorder, start_node, stop_node, wait_connected
from corde_sim.msg import WorldState

TOP = 0.75      # m, the table's top face
RADIUS = 0.003  # m, the cord's


def table_tf():
    t = TransformStamped()
    t.header.stamp = rospy.Time.now()
    t.header.frame_id = "world"
    t.child_frame_id = "table"
    t.transform.rotation.w = 1.0
    return TFMessage([t])


class RobotStart(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("robot_start_test")
        cls.scene = rospy.get_param("~scene")
        cls.urdf = rospy.get_param("~urdf")
        cls.log = Recorder("/rosout", Log, queue_size=1000)

    def node_args(self, timeout):
        return ["_scene:=" + self.scene, "_robot_urdf_file:=" + self.urdf,
                "_robot_start_timeout:=%g" % timeout, "_state_rate:=50"]

    def lines(self, node, text):
        return [m.msg for m in self.log.messages() if m.name == node and text in m.msg]

    def test_1_waits_for_late_links(self):
        states = Recorder("/rod_state", WorldState, queue_size=1000)
        tf_static = rospy.Publisher("/tf_static", TFMessage, queue_size=1, latch=True)
        node = start_node("sim_wait", self.node_args(20.0))
        try:
            time.sleep(2.0)
            wait_connected(tf_static)
            tf_static.publish(table_tf())
            deadline = time.monotonic() + 30.0
            while time.monotonic() < deadline:
                s = states.last()
                if s is not None and s.sim_time > 1.0:
                    break
                time.sleep(0.1)
            msgs = states.messages()
            self.assertTrue(msgs, "no rod_state")
            self.assertGreater(msgs[-1].sim_time, 1.0, "the simulation did not run")
            lowest = min(p.z for s in msgs for p in s.rods[0].nodes)
            # Resting on the table: the axis at most a few per cent of the radius below TOP + r.
            self.assertGreater(lowest, TOP + 0.9 * RADIUS,
                               "the cord sank into the table (lowest node z %.4f m)" % lowest)
        finally:
            stop_node(node)
            tf_static.unregister()
        # From the node's output: its first lines are logged before /rosout reaches this test.
        self.assertIn("waiting for the robot's links", node.stdout.read())

    def test_2_starts_without_links_after_timeout(self):
        node = start_node("sim_nolinks", self.node_args(1.0) + ["__ns:=other"])
        try:
            deadline = time.monotonic() + 30.0
            while time.monotonic() < deadline and not self.lines("/other/sim_nolinks",
                                                                 "starting without"):
                time.sleep(0.1)
            msg = self.lines("/other/sim_nolinks", "starting without")
            self.assertTrue(msg, "no warning after ~robot_start_timeout")
            self.assertIn("table", msg[0])
            self.assertIsNone(node.poll(), "the node stopped")
        finally:
            stop_node(node)


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "robot_start", RobotStart)
