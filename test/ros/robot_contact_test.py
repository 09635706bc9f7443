#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Robot collision (robot_contact.test).

A bar (cylinder along y, radius 2 cm) on the robot link `pusher` starts 20 cm beside a rope
(radius 1 cm, 0.5 m) hanging from (0, 0, 1) and moves through it along +x at 1 m/s, its pose sent
on /tf at 100 Hz; the node follows the link with an obstacle and the bar pushes the rope. Checked:
contacts reported in rod_state while touching, the rope's nodes near the bar moved along +x
(ahead of the bar, none left behind it), the largest penetration below 1% of the rope's radius,
contact and obstacle markers (the obstacle marker where the link is), the ignored link `finger`
not taking part (diagnostics). Then nodes started with a broken robot refuse to start and say why.
"""
import os
import subprocess
import tempfile
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from corde_rostest import (WAIT, Recorder, Sim, start_node, stop_node, transform_msg, vec,
                           wait_connected)

RADIUS = 0.01     # m, the rope's (paper_rope)
BAR = 0.02        # m, the bar's radius
HEIGHT = 0.75     # m, the bar's height: the rope's node 5
START_X, END_X = -0.2, 0.15
SPEED = 1.0       # m/s
RATE = 100.0      # Hz of the bar's tf


class Mover:
    """Publishes world -> pusher (and pusher -> finger, as robot_state_publisher would) on /tf."""

    def __init__(self):
        self.pub = rospy.Publisher("/tf", TFMessage, queue_size=10)
        self.x = START_X
        self.speed = 0.0
        self.stop = False
        self.thread = threading.Thread(target=self._run, daemon=True)

    def start(self):
        wait_connected(self.pub)
        self.thread.start()

    def _run(self):
        # Position and stamp from one clock reading: the node times the link's motion by the
        # stamps, so a stamp taken apart from the position (this thread is often descheduled
        # on a loaded machine) would make the bar's speed between messages jitter.
        last = rospy.Time.now()
        while not self.stop and not rospy.is_shutdown():
            stamp = rospy.Time.now()
            self.x = min(END_X, self.x + self.speed * (stamp - last).to_sec())
            last = stamp
            m = TFMessage()
            m.transforms = [
                transform_msg("world", "pusher", (self.x, 0.0, HEIGHT), np.eye(3), stamp),
                transform_msg("pusher", "finger", (0.0, 0.0, -0.1), np.eye(3), stamp),
            ]
            self.pub.publish(m)
            time.sleep(1.0 / RATE)


class RobotContact(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("robot_contact_test")

    def test_1_moving_link_pushes_the_rope(self):
        sim = Sim()
        markers = Recorder("/markers", MarkerArray, queue_size=50)
        diags = Recorder("/diagnostics", DiagnosticArray, queue_size=50)
        self.assertIsNotNone(sim.state.last(WAIT), "no rod_state")
        mover = Mover()
        mover.start()
        time.sleep(1.0)  # the link appears in tf; the rope is still far from it
        s = sim.fresh_state()
        self.assertEqual(s.contacts, 0, "contacts before the bar reaches the rope")
        rope0 = np.array([vec(p) for p in s.rods[0].nodes])
        t0 = time.monotonic()
        mover.speed = SPEED
        time.sleep((END_X - START_X) / SPEED + 0.6)  # the push, then 0.6 s resting against it
        t1 = time.monotonic()
        states = sim.state.messages(since=t0)
        last = sim.fresh_state()
        mover.stop = True

        touching = [m for m in states if m.contacts > 0]
        self.assertTrue(touching, "rod_state never reported a contact")
        self.assertTrue(any(m.active_contacts > 0 for m in touching), "no contact carried a force")
        pen = max(m.max_penetration for m in states)
        rospy.loginfo("robot_contact: %d states, %d with contacts (at most %d, %d active); "
                      "largest penetration %.3g m = %.2f%% of the radius", len(states),
                      len(touching), max(m.contacts for m in states),
                      max(m.active_contacts for m in states), pen, 100.0 * pen / RADIUS)
        self.assertLess(pen, 0.01 * RADIUS)

        rope = np.array([vec(p) for p in last.rods[0].nodes])
        # The rope drapes over the bar and hangs ahead of it (its free end still swings): pushed
        # along, no node moved against the push, and none behind the bar at its height (where a
        # rope the bar had passed through would hang).
        moved = rope[:, 0] - rope0[:, 0]
        rospy.loginfo("robot_contact: nodes moved along x by %s m, now at heights %s m (bar at "
                      "x = %.3f m, z = %.3f m)", np.round(moved, 3).tolist(),
                      np.round(rope[:, 2], 3).tolist(), END_X, HEIGHT)
        self.assertGreater(moved[5], 0.1)
        self.assertGreater(rope[:, 0].max(), END_X + BAR)
        self.assertTrue(np.all(moved > -0.005), "a node moved against the push")
        behind = (rope[:, 0] < END_X - BAR) & (np.abs(rope[:, 2] - HEIGHT) < BAR)
        self.assertFalse(np.any(behind), "nodes behind the bar at its height: %s" % rope[behind])

        # Markers: contact points and force arrows; the bar's obstacle marker at the link's pose.
        arrays = markers.messages(since=t0)
        names = {(m.ns, m.action) for a in arrays for m in a.markers}
        self.assertIn(("contacts", 0), names)
        self.assertIn(("contact_forces", 0), names)
        # (Waited for: markers come at 20 Hz, and this thread may have been descheduled.)
        is_bar = lambda a: any(m.ns == "obstacles" and m.action == 0 for m in a.markers)
        bar = [m for a in markers.wait(1, since=t1 - 0.1, pred=is_bar) for m in a.markers
               if m.ns == "obstacles" and m.action == 0]
        self.assertTrue(bar, "no obstacle marker")
        self.assertAlmostEqual(bar[-1].pose.position.x, END_X, delta=0.005)
        self.assertAlmostEqual(bar[-1].pose.position.z, HEIGHT, delta=0.005)

        # The ignored finger is no obstacle: 1 of 1 elements in tf. Diagnostics come once a
        # second, about as long as the push took: wait for one rather than hope one came.
        is_sim = lambda a: any(st.name.endswith("simulation") for st in a.status)
        values = [{v.key: v.value for v in st.values} for a in diags.wait(1, since=t0, pred=is_sim)
                  for st in a.status if st.name.endswith("simulation")]
        self.assertTrue(values, "no diagnostics")
        self.assertEqual(values[-1].get("robot collision elements (in tf / all)"), "1 / 1")

    def test_2_broken_robot_refuses_to_start(self):
        broken = rospy.get_param("~broken_urdf")
        scene = rospy.get_param("~scene")
        with tempfile.NamedTemporaryFile("w", suffix=".urdf", delete=False) as f:
            f.write("<robot name='half'><link name='a'>")  # not XML
            unparsable = f.name
        cases = [
            (["_robot_urdf_file:=" + broken],
             [broken, "link 'paddle'", "no_such_paddle.stl", "robot_urdf_file"]),
            (["_robot_urdf_file:=" + unparsable], [unparsable, "not a valid URDF"]),
            (["_robot_urdf_file:=" + rospy.get_param("~pusher_urdf")],
             ["link 'fingr'", "robot_ignore_links"]),
            (["_robot_collision:=true", "_robot_description:=no_such_description"],
             ["no_such_description"]),
        ]
        rospy.set_param("/broken2/robot_ignore_links", ["fingr"])  # a typo of `finger`
        procs = [(start_node("broken%d" % i, ["_scene:=" + scene] + args), args, what)
                 for i, (args, what) in enumerate(cases)]
        try:
            for p, args, what in procs:
                try:
                    out, _ = p.communicate(timeout=20.0)
                except subprocess.TimeoutExpired:
                    stop_node(p)
                    self.fail("%s: the node started instead of refusing" % args)
                self.assertNotEqual(p.returncode, 0, "%s: exit status 0\n%s" % (args, out))
                self.assertIn("cannot start", out, out)
                for w in what:
                    self.assertIn(w, out, "%s: the message does not say %s" % (args, w))
        finally:
            for p, _, _ in procs:
                stop_node(p)
            os.unlink(unparsable)


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "robot_contact", RobotContact)
