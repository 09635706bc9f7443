"""Helpers shared by the rostests of corde_sim_node (test/ros/*_test.py).

Recorders keep every message of a topic with its arrival time; service helpers wait for and
call the node's private services; small geometry helpers read poses out of tf and rod_state.
"""
import math
import os
import signal
import subprocess
import threading
import time

import numpy as np
import roslib.packages
import rospy
from geometry_msgs.msg import PoseStamped, TransformStamped
from std_srvs.srv import SetBool
from tf2_msgs.msg import TFMessage

from corde_sim.msg import WorldState
from corde_sim.srv import Configure, Grasp, Release, Reset, Step

WAIT = 20.0  # s: the node starts within this (CI machines are slow and loaded)


class Recorder:
    """Keeps (wall arrival time, message) of every message on a topic (only those published by
    node `publisher` if given: /tf carries the test's own frames too)."""

    def __init__(self, topic, msg_type, queue_size=200, publisher=None):
        self.lock = threading.Lock()
        self.items = []
        self.publisher = publisher
        self.sub = rospy.Subscriber(topic, msg_type, self._cb, queue_size=queue_size)

    def _cb(self, msg):
        if self.publisher and msg._connection_header.get("callerid") != self.publisher:
            return
        with self.lock:
            self.items.append((time.monotonic(), msg))

    def messages(self, since=None):
        with self.lock:
            return [m for (t, m) in self.items if since is None or t >= since]

    def max_gap(self, since, until):
        """The longest wall time (s) without a message between `since` and `until`."""
        with self.lock:
            times = [t for (t, _) in self.items if since <= t <= until]
        points = [since] + times + [until]
        return max(b - a for a, b in zip(points, points[1:]))

    def clear(self):
        with self.lock:
            self.items = []

    def wait(self, count=1, timeout=WAIT, since=None, pred=None):
        """Waits until `count` messages (arrived after `since`, satisfying `pred`) are there."""
        end = time.monotonic() + timeout
        while time.monotonic() < end and not rospy.is_shutdown():
            ms = [m for m in self.messages(since) if pred is None or pred(m)]
            if len(ms) >= count:
                return ms
            time.sleep(0.01)
        return [m for m in self.messages(since) if pred is None or pred(m)]

    def last(self, timeout=WAIT, since=None, pred=None):
        ms = self.wait(1, timeout, since, pred)
        return ms[-1] if ms else None

    def close(self):
        self.sub.unregister()


class Sim:
    """The node under test: its services (in `private_ns`) and outputs (in `ns`)."""

    def __init__(self, ns="", private_ns="/sim"):
        self.ns = ns.rstrip("/")
        self.pns = private_ns.rstrip("/")
        self.state = Recorder(self.ns + "/rod_state", WorldState)
        self.tf = Recorder("/tf", TFMessage, queue_size=500, publisher=self.pns)

    def service(self, name, srv_type):
        full = self.pns + "/" + name
        rospy.wait_for_service(full, timeout=WAIT)
        return rospy.ServiceProxy(full, srv_type)

    def pause(self, on=True):
        return self.service("pause", SetBool)(on)

    def step(self, steps):
        return self.service("step", Step)(steps)

    def reset(self, scene=""):
        return self.service("reset", Reset)(scene)

    def configure(self, keys=(), values=(), rod="", flags=(), flag_values=(), integrator=""):
        return self.service("configure", Configure)(rod, list(keys), list(values), list(flags),
                                                    list(flag_values), integrator)

    def grasp(self, name, rod="rope", arc_length=0.0, point=None, source="", frame=""):
        from geometry_msgs.msg import Point
        p = Point()
        if point is not None:
            p.x, p.y, p.z = point
        return self.service("grasp", Grasp)(name, rod, point is not None, arc_length, p, source,
                                            frame)

    def release(self, name):
        return self.service("release", Release)(name)

    def fresh_state(self, timeout=WAIT):
        """The first state message that arrives from now on."""
        return self.state.last(timeout, since=time.monotonic())

    def state_after(self, sim_time, timeout=WAIT):
        """The first state message at or after simulation time `sim_time`."""
        ms = self.state.wait(1, timeout, pred=lambda m: m.sim_time >= sim_time - 1e-12)
        return ms[0] if ms else None

    def paused_state(self):
        """Pauses and returns a state published after the pause took effect."""
        r = self.pause(True)
        assert r.success, r.message
        # A state published just before the pause may still be in flight: wait for a paused one.
        s = self.state.last(WAIT, since=time.monotonic(), pred=lambda m: m.paused)
        assert s is not None, "no paused rod_state within %g s" % WAIT
        return s


def wait_for_node(sim, test):
    s = sim.state.last(WAIT)
    test.assertIsNotNone(s, "no rod_state within %g s" % WAIT)
    return s


# ------------------------------------------------------------------------------------------------
# Geometry
# ------------------------------------------------------------------------------------------------
def vec(p):
    return np.array([p.x, p.y, p.z])


def quat(q):
    """(x, y, z, w) as a numpy array."""
    return np.array([q.x, q.y, q.z, q.w])


def quat_to_matrix(q):
    x, y, z, w = q / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def matrix_to_quat(m):
    w = math.sqrt(max(0.0, 1.0 + m[0, 0] + m[1, 1] + m[2, 2])) / 2.0
    x = math.sqrt(max(0.0, 1.0 + m[0, 0] - m[1, 1] - m[2, 2])) / 2.0
    y = math.sqrt(max(0.0, 1.0 - m[0, 0] + m[1, 1] - m[2, 2])) / 2.0
    z = math.sqrt(max(0.0, 1.0 - m[0, 0] - m[1, 1] + m[2, 2])) / 2.0
    x = math.copysign(x, m[2, 1] - m[1, 2])
    y = math.copysign(y, m[0, 2] - m[2, 0])
    z = math.copysign(z, m[1, 0] - m[0, 1])
    return np.array([x, y, z, w])


def rot_x(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_z(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def rotation_angle(r):
    """Angle (rad) of a rotation matrix, from its sine and cosine: acos of the trace alone
    resolves nothing below sqrt(2 eps) = 1.5e-8 rad (a turn of one ulp of a quaternion reads as
    0 or as 2.1e-8 rad, depending on the orientation's round-off)."""
    s = 0.5 * math.sqrt((r[2, 1] - r[1, 2]) ** 2 + (r[0, 2] - r[2, 0]) ** 2 +
                        (r[1, 0] - r[0, 1]) ** 2)
    return math.atan2(s, (np.trace(r) - 1.0) / 2.0)


def twist_about(r_now, r_ref, axis):
    """Signed angle of the rotation r_now r_ref^T about `axis` (assumed to be its axis)."""
    d = r_now @ r_ref.T
    w = np.array([d[2, 1] - d[1, 2], d[0, 2] - d[2, 0], d[1, 0] - d[0, 1]])
    return math.atan2(0.5 * np.dot(w, axis), (np.trace(d) - 1.0) / 2.0)


def segment_pose(rod, k):
    """(midpoint, rotation matrix) of segment k of a corde_sim/RodState."""
    mid = 0.5 * (vec(rod.nodes[k]) + vec(rod.nodes[k + 1]))
    return mid, quat_to_matrix(quat(rod.orientations[k]))


def transform_pose(t):
    """(translation, rotation matrix) of a geometry_msgs/Transform."""
    return vec(t.translation), quat_to_matrix(quat(t.rotation))


def frames_in(tf_messages, child):
    """Every TransformStamped with this child frame, in arrival order."""
    return [t for m in tf_messages for t in m.transforms if t.child_frame_id == child]


def finite_state(s):
    vals = [s.sim_time, s.time_step, s.step_time_us, s.real_time_factor]
    for r in s.rods:
        vals += [r.kinetic_energy, r.elastic_energy]
        for p in list(r.nodes) + list(r.velocities) + list(r.angular_velocities):
            vals += [p.x, p.y, p.z]
        for q in r.orientations:
            vals += [q.x, q.y, q.z, q.w]
    return all(math.isfinite(v) for v in vals)


def finite_tf(m):
    for t in m.transforms:
        v = [t.transform.translation.x, t.transform.translation.y, t.transform.translation.z,
             t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
             t.transform.rotation.w]
        if not all(math.isfinite(x) for x in v):
            return False
    return True


def pose_msg(p, r, frame="world", stamp=None):
    m = PoseStamped()
    m.header.frame_id = frame
    m.header.stamp = rospy.Time.now() if stamp is None else stamp
    m.pose.position.x, m.pose.position.y, m.pose.position.z = p
    q = matrix_to_quat(r)
    m.pose.orientation.x, m.pose.orientation.y, m.pose.orientation.z, m.pose.orientation.w = q
    return m


def transform_msg(parent, child, p, r, stamp=None):
    t = TransformStamped()
    t.header.frame_id = parent
    t.header.stamp = rospy.Time.now() if stamp is None else stamp
    t.child_frame_id = child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = p
    q = matrix_to_quat(r)
    t.transform.rotation.x, t.transform.rotation.y = q[0], q[1]
    t.transform.rotation.z, t.transform.rotation.w = q[2], q[3]
    return t


def wait_connected(pub, timeout=10.0):
    end = time.monotonic() + timeout
    while pub.get_num_connections() == 0 and time.monotonic() < end:
        time.sleep(0.02)
    return pub.get_num_connections() > 0


def valid_state(s, max_speed=100.0):
    """Finite, unit quaternions, no node faster than max_speed: what the node promises to publish."""
    if not finite_state(s):
        return False
    for r in s.rods:
        for q in r.orientations:
            if abs(math.sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w) - 1.0) > 1e-6:
                return False
        for v in r.velocities:
            if np.linalg.norm(vec(v)) > max_speed:
                return False
    return True


def valid_tf(m):
    """Finite transforms with unit quaternions (tf2 rejects zero ones as denormalized)."""
    if not finite_tf(m):
        return False
    for t in m.transforms:
        q = t.transform.rotation
        if abs(math.sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w) - 1.0) > 1e-6:
            return False
    return True


class RosoutRecorder(Recorder):
    """Log lines of one node (from /rosout), for checking the text of its warnings."""

    def __init__(self, node="/sim"):
        from rosgraph_msgs.msg import Log
        super().__init__("/rosout", Log, queue_size=1000)
        self.node = node

    def lines(self, since=None, contains=""):
        return [m.msg for m in self.messages(since) if m.name == self.node and contains in m.msg]


def start_node(name, args):
    """A corde_sim_node named `name` with private parameters `args` (`_key:=value`), in its own
    process group so that stop_node also ends its children; output captured as text."""
    # roslib finds the node where roslaunch does; rosrun skips <package>/build, where ours is.
    cmd = [roslib.packages.find_node("corde_sim", "corde_sim_node")[0], "__name:=" + name]
    return subprocess.Popen(cmd + args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True, start_new_session=True)


def stop_node(p):
    """SIGINT, then SIGKILL after 10 s, to a node started by start_node."""
    if p.poll() is None:
        os.killpg(p.pid, signal.SIGINT)
        try:
            p.wait(10)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()
