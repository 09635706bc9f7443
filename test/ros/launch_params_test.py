#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""corde_sim.launch does not inherit grasp parameters an earlier launch left on the master
(launch_params.test)."""
import os
import signal
import subprocess
import unittest

import rospy
import rostest

import corde_rostest as ct
from corde_sim.srv import ListGrasps

NODE = "leaky"


class LaunchParams(unittest.TestCase):
    def test_stale_grasp_parameters_are_cleared(self):
        rospy.init_node("launch_params_test")
        # What robot_example.launch leaves behind, and a grasp name the default scene lacks.
        rospy.set_param("/%s/grasps/gripper" % NODE, {"source": "tf", "frame": "tool"})
        rospy.set_param("/%s/grasps/stale" % NODE, {"source": "fixed"})
        launch = subprocess.Popen(
            ["roslaunch", "corde_sim", "corde_sim.launch", "headless:=true",
             "node_name:=" + NODE],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
        try:
            rospy.wait_for_service("/%s/list_grasps" % NODE, timeout=ct.WAIT)
            g = rospy.ServiceProxy("/%s/list_grasps" % NODE, ListGrasps)()
            self.assertEqual(list(g.names), ["gripper"])
            self.assertEqual(g.sources[0], "topic", "grasps/gripper of the earlier launch leaked")
            self.assertEqual(g.frames[0], "")
            grasps = rospy.get_param("/%s/grasps" % NODE, {})
            self.assertNotIn("stale", grasps)
            self.assertNotIn("gripper", grasps)
        finally:
            if launch.poll() is None:
                os.killpg(launch.pid, signal.SIGINT)
                try:
                    launch.wait(15)
                except subprocess.TimeoutExpired:
                    os.killpg(launch.pid, signal.SIGKILL)
                    launch.wait()


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "launch_params", LaunchParams)
