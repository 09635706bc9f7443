#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and the generated messages.)
"""Issue 22, node part: a hostile client does not crash, wedge or bloat the node
(hostile_client.test)."""
import math
import threading
import time
import unittest
import xmlrpc.client

import numpy as np
import rosgraph
import rosnode
import rospy
import rostest
from dynamic_reconfigure.client import Client
from geometry_msgs.msg import PoseStamped, WrenchStamped
from std_msgs.msg import Float64

import corde_rostest as ct
from corde_sim.srv import ListGrasps

NAN, INF = float("nan"), float("inf")
MAX_GAP = 0.5  # s without rod_state (always) or tf (while running)
MAX_RSS_GROWTH_KB = 40 * 1024
DEFAULTS = {"real_time_factor": 1.0, "tf_rate": 50.0, "marker_rate": 20.0, "state_rate": 50.0,
            "holder_max_speed": 2.0, "holder_max_acceleration": 50.0,
            "marker_min_diameter": 0.004}


def node_pid(name):
    uri = rosnode.get_api_uri(rosgraph.Master("/hostile_client_test"), name)
    code, _, pid = xmlrpc.client.ServerProxy(uri).getPid("/hostile_client_test")
    assert code == 1
    return pid


def rss_kb(pid):
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def gaps(times, since, until, skip=()):
    """(length, start) of the largest interval without a message in [since, until], leaving out
    intervals that overlap the windows `skip` (extended by 0.3 s: the first frames after
    resuming)."""
    points = sorted([since, until] + [t for t in times if since <= t <= until])
    worst = (0.0, since)
    for a, b in zip(points, points[1:]):
        if any(a <= e + 0.3 and b >= s for (s, e) in skip):
            continue
        worst = max(worst, (b - a, a))
    return worst


class HostileClient(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("hostile_client_test")
        cls.sim = ct.Sim()
        assert cls.sim.state.last() is not None
        cls.pid = node_pid("/sim")
        cls.pose_pub = rospy.Publisher("/grasps/gripper/pose", PoseStamped, queue_size=1000)
        cls.wrench_pub = rospy.Publisher("/grasps/gripper/wrench", WrenchStamped, queue_size=100)
        cls.rate_pub = rospy.Publisher("/grasps/gripper/twist_rate", Float64, queue_size=100)
        assert ct.wait_connected(cls.pose_pub)
        assert ct.wait_connected(cls.wrench_pub)
        assert ct.wait_connected(cls.rate_pub)

    def flood(self, p0, r0, stop):
        """Poses in bursts: bad ones (NaN, inf, non-unit, absurd but finite, long frame ids)
        mixed with good ones near p0."""
        i = 0
        self.sent = 0
        while not stop.is_set():
            for _ in range(200):  # a burst
                i += 1
                kind = i % 7
                if kind == 0:
                    m = ct.pose_msg(p0 + [0.0, 0.0, 0.01 * math.sin(i * 0.01)], r0)
                elif kind == 1:
                    m = ct.pose_msg((NAN, 0.0, 1.0), r0)
                elif kind == 2:
                    m = ct.pose_msg((1e300, -1e300, 1e300), r0)
                elif kind == 3:
                    m = ct.pose_msg(p0, r0)
                    m.pose.orientation.w = 7.0
                elif kind == 4:
                    m = ct.pose_msg(p0, r0, frame="nowhere_" + "x" * 20000)
                elif kind == 5:
                    m = ct.pose_msg(p0, r0, stamp=rospy.Time(1e9))
                else:
                    m = ct.pose_msg(p0, r0)
                    m.pose.orientation.x = INF
                self.pose_pub.publish(m)
                self.sent += 1
            w = WrenchStamped()
            w.header.frame_id = "world"
            w.header.stamp = rospy.Time.now()
            w.wrench.force.x = NAN
            self.wrench_pub.publish(w)
            self.rate_pub.publish(Float64(INF if i % 2 else 1e300))
            time.sleep(0.02)

    def mark(self, what):
        self.marks.append((time.monotonic(), what))

    def phase_at(self, t):
        """What the test was doing at time t."""
        return ([w for (m, w) in self.marks if m <= t] or ["start"])[-1]

    def abuse_services(self):
        sim = self.sim
        self.mark("reconfigure")
        client = Client("/sim", timeout=ct.WAIT)
        huge = "h" * (1 << 20)
        replies = []
        # Reconfigure: non-finite, huge, long strings.
        for key in ["real_time_factor", "tf_rate", "marker_rate", "state_rate",
                    "holder_max_speed", "holder_max_acceleration", "marker_min_diameter"]:
            for v in [NAN, INF, -INF, 1e300, -1e300]:
                if key.endswith("_rate") and not math.isnan(v):
                    # dynamic_reconfigure clamps these to 0 ("off") or 1000 Hz (which this
                    # Python process cannot follow): asked for, not hostile.
                    continue
                client.update_configuration({key: v})
        client.update_configuration({"marker_style": huge})
        client.update_configuration({"marker_style": "line_strip"})
        client.update_configuration({"marker_style": "cylinders"})
        client.update_configuration(DEFAULTS)
        # Services, bad and good.
        self.mark("services")
        replies.append(sim.step(1000))  # refused: running
        replies.append(sim.configure(["time_step"], [1e-300]))
        replies.append(sim.configure(["time_step", "E"], [NAN, INF]))
        replies.append(sim.configure(["elements"], [1e300]))
        replies.append(sim.configure([huge], [1.0]))
        replies.append(sim.configure(integrator=huge))
        replies.append(sim.grasp(huge, arc_length=0.2))
        replies.append(sim.grasp("bad name!", arc_length=0.2))
        replies.append(sim.grasp("x", rod=huge, arc_length=0.2))
        replies.append(sim.grasp("x", arc_length=NAN))
        replies.append(sim.grasp("x", point=(NAN, INF, 0.0)))
        replies.append(sim.grasp("x", arc_length=0.2, source="tf", frame=huge))
        replies.append(sim.release(huge))
        replies.append(sim.reset(huge))
        replies.append(sim.reset("/dev/zero"))
        sim.service("list_grasps", ListGrasps)()
        self.mark("pause and step")
        # A paused stretch with a huge ~step (queued, run between outputs), then resumed.
        pause_start = time.monotonic()
        sim.pause(True)
        replies.append(sim.step(2000000))
        sim.pause(True)
        time.sleep(0.5)
        sim.pause(False)
        pause_end = time.monotonic()
        # Grasp churn: many uniquely named run-time grasps made and let go.
        self.mark("grasp churn")
        for i in range(300):
            name = "churn_%d_%s" % (i, "c" * 100)
            r = sim.grasp(name, arc_length=0.2)
            self.assertTrue(r.success, r.message[:300])
            r = sim.release(name)
            self.assertTrue(r.success, r.message[:300])
        for r in replies:
            self.assertLess(len(r.message), 600, r.message[:300] + "...")
        return (pause_start, pause_end)

    def test_hostile_client(self):
        s0 = self.sim.fresh_state()
        p0, r0 = ct.segment_pose(s0.rods[0], 9)
        time.sleep(0.5)
        rss0 = rss_kb(self.pid)
        self.marks = []
        since = time.monotonic()
        stop = threading.Event()
        flooder = threading.Thread(target=self.flood, args=(p0, r0, stop))
        flooder.start()
        try:
            paused = self.abuse_services()
            time.sleep(2.0)
            rss1 = rss_kb(self.pid)
            # Again: memory must not keep growing with the same traffic.
            paused2 = self.abuse_services()
            time.sleep(1.0)
        finally:
            stop.set()
            flooder.join()
        until = time.monotonic()
        rss2 = rss_kb(self.pid)
        states = self.sim.state.messages(since)
        tfs = self.sim.tf.messages(since)
        state_times = [t for (t, _) in self.sim.state.items]
        tf_times = [t for (t, _) in self.sim.tf.items]
        self.assertGreater(self.sent, 5000, "the pose flood stopped early")
        state_gap, at = gaps(state_times, since, until)
        state_phase = self.phase_at(at)
        self.assertLess(state_gap, MAX_GAP, "rod_state silent for %.2f s (during %s)" %
                        (state_gap, self.phase_at(at)))
        tf_gap, at = gaps(tf_times, since, until, skip=[paused, paused2])
        tf_phase = self.phase_at(at)
        self.assertLess(tf_gap, MAX_GAP, "tf silent for %.2f s while running (during %s)" %
                        (tf_gap, self.phase_at(at)))
        self.assertTrue(all(ct.finite_state(s) for s in states), "a rod_state carried NaN")
        self.assertTrue(all(ct.finite_tf(m) for m in tfs), "a tf message carried NaN")
        rospy.loginfo("hostile_client: %d poses in %.1f s; largest gaps: rod_state %.3f s (during "
                      "%s), tf %.3f s (during %s); VmRSS %d kB at start, %d after one round, %d "
                      "after two", self.sent, until - since, state_gap, state_phase, tf_gap,
                      tf_phase, rss0, rss1, rss2)
        self.assertLess(rss2 - rss0, MAX_RSS_GROWTH_KB)
        self.assertLess(rss2 - rss1, 8 * 1024, "memory grows with each round of traffic")
        names = self.sim.service("list_grasps", ListGrasps)().names
        self.assertEqual(list(names), ["gripper"])
        # Recovery: a normal pose still moves the grasp.
        s = self.sim.fresh_state()
        p, r = ct.segment_pose(s.rods[0], 9)
        target = p + np.array([0.0, 0.0, 0.03])
        for _ in range(20):
            self.pose_pub.publish(ct.pose_msg(target, r))
            time.sleep(0.05)
        s = self.sim.fresh_state()
        moved, _ = ct.segment_pose(s.rods[0], 9)
        self.assertLess(np.linalg.norm(moved - target), 0.005, (moved, target))


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "hostile_client", HostileClient)
