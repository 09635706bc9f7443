#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""corde_sim.launch does not inherit grasp parameters an earlier launch left on the master, and
the node under it is what docs/ros_interface.md says: its diagnostics status is
'<node name>: simulation', and it subscribes to the topics of its own grasps only
(launch_params.test)."""
import os
import signal
import subprocess
import unittest

import rosgraph
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray

import corde_rostest as ct
from corde_sim.srv import ListGrasps

NODE = "leaky"


class LaunchParams(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("launch_params_test")
        # What robot_example.launch leaves behind, and a grasp name the default scene lacks.
        rospy.set_param("/%s/grasps/gripper" % NODE, {"source": "tf", "frame": "tool"})
        rospy.set_param("/%s/grasps/stale" % NODE, {"source": "fixed"})
        cls.diag = ct.Recorder("/diagnostics", DiagnosticArray)
        cls.launch = subprocess.Popen(
            ["roslaunch", "corde_sim", "corde_sim.launch", "headless:=true",
             "node_name:=" + NODE],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
        rospy.wait_for_service("/%s/list_grasps" % NODE, timeout=ct.WAIT)

    @classmethod
    def tearDownClass(cls):
        if cls.launch.poll() is None:
            os.killpg(cls.launch.pid, signal.SIGINT)
            try:
                cls.launch.wait(15)
            except subprocess.TimeoutExpired:
                os.killpg(cls.launch.pid, signal.SIGKILL)
                cls.launch.wait()

    def test_stale_grasp_parameters_are_cleared(self):
        g = rospy.ServiceProxy("/%s/list_grasps" % NODE, ListGrasps)()
        self.assertEqual(list(g.names), ["gripper"])
        self.assertEqual(g.sources[0], "topic", "grasps/gripper of the earlier launch leaked")
        self.assertEqual(g.frames[0], "")
        grasps = rospy.get_param("/%s/grasps" % NODE, {})
        self.assertNotIn("stale", grasps)
        self.assertNotIn("gripper", grasps)

    def test_diagnostics_status_is_named_after_the_node(self):
        ms = self.diag.wait(1, pred=lambda m: any(st.hardware_id == "corde_sim" for st in m.status))
        self.assertTrue(ms, "no diagnostics from the node within %g s" % ct.WAIT)
        names = {st.name for st in ms[0].status if st.hardware_id == "corde_sim"}
        self.assertEqual(names, {NODE + ": simulation"})

    def test_only_the_grasps_topics_are_subscribed(self):
        # A pose for a name the node has no grasp for reaches nobody (docs: lost without a
        # warning); its own grasp's topic has the node as subscriber.
        _, subscribers, _ = rosgraph.Master("/launch_params_test").getSystemState()
        subs = dict(subscribers)
        self.assertIn("/" + NODE, subs.get("/grasps/gripper/pose", []))
        self.assertNotIn("/grasps/griper/pose", subs)
        self.assertNotIn("/grasps/stale/pose", subs)


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "launch_params", LaunchParams)
