#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Start-up refusals of corde_sim_node (startup_params.test): each bad parameter makes it exit
with a non-zero status and a message naming the parameter; good ones start it."""
import subprocess
import time
import unittest

import rospy
import rostest

import corde_rostest as ct

# (private parameter arguments, text the output must contain)
BAD = [
    (["_publish_clock:=true"], "publish_clock"),  # /use_sim_time is not true
    (["_tf_every_k:=0"], "tf_every_k"),
    (["_real_time_factor:=-1.0"], "real_time_factor"),
    (["_tf_rate:=-5.0"], "tf_rate"),
    (["_tf_rate:=fast"], "tf_rate"),  # wrong type
    # Beyond the key-range table's 1000 Hz, worded as ~configure words it.
    (["_tf_rate:=5000.0"],
     "parameter ~tf_rate: must be <= 1000 Hz, got 5000 (valid: [0, 1000] Hz)"),
    (["_tf_every_k:=2.5"], "tf_every_k"),  # not an integer
    (["_show_frames:=maybe"], "show_frames"),  # not a bool
    (["_max_pose_age:=0.0"], "max_pose_age"),
    (["_status_period:=-1.0"], "status_period"),
    (["_world_frame:=/world"], "world_frame"),
    (["_marker_style:=spaghetti"], "marker_style"),
    (["_scene:=/no/such/scene.yaml"], "scene"),
    (["_overrides:=rods.0.elements=-4"], "elements"),
    (["_grasps/gripper/source:=magic"], "grasps/gripper/source"),
    (["_integrator:=rk4"], "integrator"),
]


def start(name, args, scene):
    if not any(a.startswith("_scene:=") for a in args):
        args = args + ["_scene:=" + scene]
    return ct.start_node(name, args)


class StartupParams(unittest.TestCase):
    def test_bad_parameters_refuse_start(self):
        rospy.init_node("startup_params_test")
        self.assertFalse(rospy.get_param("/use_sim_time", False))
        scene = rospy.get_param("~scene")
        procs = [(start("bad%d" % i, args, scene), args, what) for i, (args, what) in enumerate(BAD)]
        good = start("good", ["_integrator:=implicit_euler"], scene)
        try:
            end = time.monotonic() + 30.0
            for p, args, what in procs:
                try:
                    out, _ = p.communicate(timeout=max(1.0, end - time.monotonic()))
                except subprocess.TimeoutExpired:
                    ct.stop_node(p)
                    self.fail("%s: the node started instead of refusing" % args)
                self.assertNotEqual(p.returncode, 0, "%s: exit status 0\n%s" % (args, out))
                self.assertIn(what, out, "%s: the message does not name it" % args)
                self.assertIn("cannot start", out, args)
            # The same command with good parameters runs (and is still running now).
            self.assertIsNone(good.poll(), "the node with good parameters exited")
        finally:
            for p, _, _ in procs:
                ct.stop_node(p)
            ct.stop_node(good)


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "startup_params", StartupParams)
