#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Issue 22, node part: limits on what a client may ask (node_limits.test)."""
import math
import os
import tempfile
import time
import unittest

import rosgraph
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from dynamic_reconfigure.client import Client
from geometry_msgs.msg import PoseStamped

import corde_rostest as ct
from corde_sim.srv import ListGrasps

ECHO = 100  # characters of an input a reply may echo
REPLY_MAX = 600  # characters: a reply echoing a clipped input and its explanation


class NodeLimits(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("node_limits_test")
        cls.sim = ct.Sim()
        cls.diag = ct.Recorder("/diagnostics", DiagnosticArray)
        cls.log = ct.RosoutRecorder("/sim")
        assert cls.sim.state.last() is not None

    def tearDown(self):
        self.sim.pause(False)

    def short(self, message):
        self.assertLess(len(message), REPLY_MAX, message[:REPLY_MAX] + "...")

    # Item 4: a huge ~step is queued and run in batches; rod_state keeps its rate meanwhile.
    def test_1_step_is_queued(self):
        self.sim.paused_state()
        since = time.monotonic()
        r = self.sim.step(10000000)  # many seconds of stepping
        took = time.monotonic() - since
        self.assertTrue(r.success, r.message)
        self.assertLess(took, 1.0, "~step held the loop for %.1f s" % took)
        self.assertIn("queued", r.message)
        time.sleep(1.5)
        until = time.monotonic()
        gap = self.sim.state.max_gap(since, until)
        self.assertLess(gap, 0.3, "rod_state silent for %.2f s during a queued ~step" % gap)
        states = self.sim.state.messages(since)
        self.assertGreater(states[-1].sim_time, r.time)  # the queue runs while paused
        self.assertTrue(states[-1].paused)
        # Resuming drops what is left of the queue (said in the reply).
        r2 = self.sim.pause(False)
        self.assertTrue(r2.success)
        self.assertIn("dropped", r2.message)

    # Item 5: a time step too small to advance the clock is refused.
    def test_2_tiny_time_step(self):
        r = self.sim.configure(["time_step"], [1e-300])
        self.assertFalse(r.success, r.message)
        self.assertIn("time_step", r.message)
        self.assertIn("1e-09", r.message)
        s = self.sim.fresh_state()
        self.assertEqual(s.time_step, 2.5e-4)

    # Item 6: non-finite and out-of-range reconfigure values keep the previous value.
    def test_3_reconfigure_nan(self):
        client = Client("/sim", timeout=ct.WAIT)
        since = time.monotonic()
        for key, kept in [("state_rate", 50.0), ("tf_rate", 50.0), ("holder_max_speed", 2.0),
                          ("holder_max_acceleration", 50.0), ("real_time_factor", 1.0),
                          ("marker_min_diameter", 0.004)]:
            c = client.update_configuration({key: float("nan")})
            self.assertEqual(c[key], kept, "%s nan: reply shows %r" % (key, c[key]))
            # (dynamic_reconfigure itself clamps infinities to the range: finite in the reply)
            c = client.update_configuration({key: float("inf")})
            self.assertTrue(math.isfinite(c[key]), "%s inf: reply shows %r" % (key, c[key]))
            client.update_configuration({key: kept})
        c = client.update_configuration({"marker_style": "x" * 1000000})
        self.assertEqual(c["marker_style"], "cylinders")
        time.sleep(1.0)
        rate = len(self.sim.state.messages(since + 0.5)) / (time.monotonic() - since - 0.5)
        self.assertGreater(rate, 35.0)
        warnings = self.log.lines(since, "reconfigure")
        self.assertTrue(any("state_rate" in w and "nan" in w for w in warnings), warnings)
        self.assertTrue(all(len(w) < REPLY_MAX for w in warnings), [w[:200] for w in warnings])

    # Item 7: poses sent while paused do not pile up (only the newest per grasp is kept).
    def test_4_poses_while_paused(self):
        s = self.sim.paused_state()
        p0, r0 = ct.segment_pose(s.rods[0], 9)
        pub = rospy.Publisher("/grasps/gripper/pose", PoseStamped, queue_size=1000)
        self.assertTrue(ct.wait_connected(pub))
        for i in range(3000):
            pub.publish(ct.pose_msg(p0 + [0.0, 0.0, 1e-5 * (i % 100)], r0))
            if i % 100 == 0:
                time.sleep(0.01)
        time.sleep(1.0)
        since = time.monotonic()

        def queued(m):
            for st in m.status:
                for kv in st.values:
                    if kv.key == "queued inputs":
                        return int(kv.value)
            return None

        d = self.diag.last(since=since, pred=lambda m: queued(m) is not None, timeout=5.0)
        self.assertIsNotNone(d, "no 'queued inputs' in diagnostics")
        self.assertLessEqual(queued(d), 3)
        pub.unregister()

    # Item 7: a released run-time grasp leaves nothing behind; the grasp count is bounded.
    def test_5_grasp_churn(self):
        for i in range(40):
            name = "churn_%d" % i
            r = self.sim.grasp(name, arc_length=0.2)
            self.assertTrue(r.success, r.message)
            r = self.sim.release(name)
            self.assertTrue(r.success, r.message)
        names = self.sim.service("list_grasps", ListGrasps)().names
        self.assertEqual(list(names), ["gripper"])
        state = rosgraph.Master("/node_limits_test").getSystemState()
        topics = [t for group in state[:2] for (t, nodes) in group if "/sim" in nodes]
        self.assertFalse([t for t in topics if "churn" in t], [t for t in topics if "churn" in t])

    def test_6_grasp_count_bounded(self):
        r = self.sim.configure(["elements"], [300], integrator="implicit_euler")
        self.assertTrue(r.success, r.message)
        made = []
        message = ""
        for i in range(100):
            r = self.sim.grasp("many_%d" % i, arc_length=0.01 + i * 0.0045)
            if not r.success:
                message = r.message
                break
            made.append("many_%d" % i)
        self.assertLess(len(made), 100)
        self.assertIn("64", message)
        self.assertIn("grasps", message)
        for n in made:
            self.assertTrue(self.sim.release(n).success)
        r = self.sim.reset()
        self.assertTrue(r.success, r.message)

    # Item 8: names are bounded and echoes are clipped.
    def test_7_long_names(self):
        huge = "g" * (1 << 20)
        for call in [lambda: self.sim.grasp(huge, arc_length=0.2),
                     lambda: self.sim.grasp("ok", rod=huge, arc_length=0.2),
                     lambda: self.sim.grasp("ok", arc_length=0.2, source="tf", frame=huge),
                     lambda: self.sim.grasp("ok", arc_length=0.2, source=huge),
                     lambda: self.sim.release(huge),
                     lambda: self.sim.reset(huge),
                     lambda: self.sim.reset("/" + huge),
                     lambda: self.sim.configure([huge], [1.0]),
                     lambda: self.sim.configure(["E"], [1.0], rod=huge),
                     lambda: self.sim.configure(["E"], [1e6], flags=[huge], flag_values=[True]),
                     lambda: self.sim.configure(integrator=huge)]:
            since = time.monotonic()
            r = call()
            self.assertLess(time.monotonic() - since, 2.0)
            self.assertFalse(r.success)
            self.short(r.message)
        r = self.sim.grasp("n" * 257, arc_length=0.2)
        self.assertFalse(r.success)
        self.assertIn("256", r.message)
        r = self.sim.grasp("n" * 256, arc_length=0.2)
        self.assertTrue(r.success, r.message)
        self.assertTrue(self.sim.release("n" * 256).success)
        # A pose with a huge frame_id: the warning clips it.
        since = time.monotonic()
        pub = rospy.Publisher("/grasps/gripper/pose", PoseStamped, queue_size=10)
        self.assertTrue(ct.wait_connected(pub))
        s = self.sim.fresh_state()
        p0, r0 = ct.segment_pose(s.rods[0], 9)
        for _ in range(5):
            pub.publish(ct.pose_msg(p0, r0, frame="f" * (1 << 20)))
            time.sleep(0.05)
        lines = self.log.wait(1, timeout=5.0, since=since,
                              pred=lambda m: m.name == "/sim" and "rejected" in m.msg)
        self.assertTrue(lines)
        for m in lines:
            self.short(m.msg)
        pub.unregister()

    # Item 9: a device or FIFO as the scene file is refused at once.
    def test_8_special_files(self):
        fifo = os.path.join(tempfile.mkdtemp(), "scene.yaml")
        os.mkfifo(fifo)
        for path in ["/dev/zero", fifo, "/dev/null"]:
            since = time.monotonic()
            r = self.sim.reset(path)
            self.assertLess(time.monotonic() - since, 2.0)
            self.assertFalse(r.success)
            self.assertIn("regular file", r.message)
            self.assertIn(path, r.message)
        self.assertIsNotNone(self.sim.fresh_state(timeout=2.0))


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "node_limits", NodeLimits)
