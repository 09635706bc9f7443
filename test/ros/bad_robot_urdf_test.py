#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Bad robot descriptions and URDF obstacles (bad_robot_urdf.test).

Nodes started with a broken robot refuse to start and say why (parameter, link, element, value);
the running node's ~reset to a scene with a broken URDF obstacle fails with the reason while the
simulation goes on, and a 10000-link chain loads.
"""
import os
import shutil
import subprocess
import tempfile
import time
import unittest

import rospy
import rostest

import corde_rostest as ct


def table(collision):
    return "<robot name='t'><link name='table'>%s</link></robot>" % collision


def box(size, origin=""):
    return "<collision>%s<geometry><box size='%s'/></geometry></collision>" % (origin, size)


def chain(n):
    parts = ["<robot name='chain'><link name='l0'>%s</link>" % box("1 1 0.1")]
    for i in range(1, n):
        parts.append("<link name='l%d'/><joint name='j%d' type='fixed'><parent link='l%d'/>"
                     "<child link='l%d'/></joint>" % (i, i, i - 1, i))
    return "\n".join(parts + ["</robot>"])


class BadRobotUrdf(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("bad_robot_urdf_test")
        cls.sim = ct.Sim()
        cls.dir = tempfile.mkdtemp(prefix="corde_bad_urdf_")

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.dir, ignore_errors=True)

    def write(self, name, text):
        path = os.path.join(self.dir, name)
        with open(path, "w") as f:
            f.write(text)
        return path

    def test_1_broken_robot_refuses_to_start(self):
        fifo = os.path.join(self.dir, "fifo.urdf")
        os.mkfifo(fifo)
        text = self.write("notes.urdf", "just some words\n")
        descriptions = {
            "/bad_comma": (table(box("1,1,0.1")), ["link 'table' collision 0", "1,1,0.1"]),
            "/bad_nan": (table(box("1 1 1", "<origin xyz='nan 0 0'/>")),
                         ["link 'table' collision 0", "nan"]),
            "/bad_huge": (table("<collision><geometry><sphere radius='1e308'/></geometry>"
                                "</collision>"), ["link 'table' collision 0", "sphere radius"]),
            "/bad_empty": (table("<collision><geometry></geometry></collision>"),
                           ["link 'table' collision 0", "empty <geometry>"]),
        }
        cases = []
        for name, (xml, what) in descriptions.items():
            rospy.set_param(name, xml)
            cases.append((["_robot_collision:=true", "_robot_description:=" + name[1:]],
                          ["parameter ~robot_collision", "parameter " + name] + what))
        cases.append((["_robot_urdf_file:=" + fifo],
                      ["parameter ~robot_urdf_file", fifo, "not a regular file"]))
        cases.append((["_robot_urdf_file:=" + text],
                      ["parameter ~robot_urdf_file", text, "not a URDF (no <robot> element)"]))
        scene = rospy.get_param("~scene")
        procs = [(ct.start_node("broken_urdf%d" % i, ["_scene:=" + scene] + args), args, what)
                 for i, (args, what) in enumerate(cases)]
        try:
            for p, args, what in procs:
                try:
                    out, _ = p.communicate(timeout=30.0)
                except subprocess.TimeoutExpired:
                    ct.stop_node(p)
                    self.fail("%s: the node started (or hung) instead of refusing" % args)
                self.assertNotEqual(p.returncode, 0, "%s: exit status 0\n%s" % (args, out))
                self.assertIn("cannot start", out, out)
                for w in what:
                    self.assertIn(w, out, "%s: the message does not say %s:\n%s" % (args, w, out))
        finally:
            for p, _, _ in procs:
                ct.stop_node(p)

    def scene_with(self, urdf):
        """The test's scene with the URDF file `urdf` as an obstacle well below the rope."""
        with open(rospy.get_param("~scene")) as f:
            text = f.read()
        return self.write("scene_%d.yaml" % len(os.listdir(self.dir)),
                          text + "obstacles:\n  - {name: robot, urdf: %s, position: [0, 0, -5]}\n"
                          % urdf)

    def test_2_reset_to_bad_urdf_keeps_running(self):
        bad = self.write("bad.urdf", table(box("1,1,0.1")))
        r = self.sim.reset(self.scene_with(bad))
        self.assertFalse(r.success, r.message)
        self.assertIn("obstacles[0].urdf", r.message)
        self.assertIn("link 'table' collision 0", r.message)
        r = self.sim.reset(self.scene_with('""'))
        self.assertFalse(r.success, r.message)
        self.assertIn("obstacles[0].urdf: the path is empty", r.message)
        # A URDF of /dev/zero used to leave ~reset unanswered for a minute while memory grew.
        t0 = time.time()
        r = self.sim.reset(self.scene_with("/dev/zero"))
        self.assertFalse(r.success, r.message)
        self.assertIn("/dev/zero: is not a regular file", r.message)
        self.assertLess(time.time() - t0, 5.0, "~reset took too long to refuse /dev/zero")
        # The simulation goes on.
        s0 = self.sim.fresh_state()
        self.assertIsNotNone(s0)
        s1 = self.sim.state_after(s0.sim_time + 0.05)
        self.assertIsNotNone(s1, "the simulation stopped after a failed reset")

    def test_3_reset_to_deep_chain_loads(self):
        # 10000 links used to overflow the stack in the link walk and kill the node.
        deep = self.write("chain.urdf", chain(10000))
        r = self.sim.reset(self.scene_with(deep))
        self.assertTrue(r.success, r.message)
        s0 = self.sim.fresh_state()
        self.assertIsNotNone(s0)
        self.assertIsNotNone(self.sim.state_after(s0.sim_time + 0.05))


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "bad_robot_urdf", BadRobotUrdf)
