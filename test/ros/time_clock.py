"""Helpers of the time rostests (time_*_test.py): a /clock the test controls, a recorder that
keeps each message with the clock shown when it arrived, the check of stamps against that clock,
and a node started with its output in a file (a pipe would fill up and block it)."""
import os
import signal
import subprocess
import tempfile
import threading
import time

import roslib.packages
import rospy
from rosgraph_msgs.msg import Clock


class ClockPublisher:
    """Publishes /clock at 200 Hz: `start` + `rate` times the wall time elapsed, until paused, or
    moved by jump()."""

    def __init__(self, start, rate=1.0):
        self.rate = rate
        self.pub = rospy.Publisher("/clock", Clock, queue_size=10)
        self.lock = threading.Lock()
        self.base = start
        self.mono0 = time.monotonic()
        self.running = True
        self.stop = False
        self.thread = threading.Thread(target=self._loop, daemon=True)
        self.thread.start()

    def _now(self):
        return self.base + (self.rate * (time.monotonic() - self.mono0) if self.running else 0.0)

    def now(self):
        with self.lock:
            return self._now()

    def pause(self):
        with self.lock:
            self.base = self._now()
            self.running = False

    def resume(self):
        with self.lock:
            self.mono0 = time.monotonic()
            self.running = True

    def jump(self, seconds):
        with self.lock:
            self.base = self._now() + seconds
            self.mono0 = time.monotonic()

    def _loop(self):
        while not self.stop and not rospy.is_shutdown():
            with self.lock:
                self.pub.publish(Clock(clock=rospy.Time.from_sec(self._now())))
            time.sleep(0.005)


class ClockRecorder:
    """Keeps (time of `clock` at arrival, message) of every message on a topic; `clock` is a
    function returning the current clock time (s)."""

    def __init__(self, topic, msg_type, clock):
        self.lock = threading.Lock()
        self.items = []
        self.clock = clock
        self.sub = rospy.Subscriber(topic, msg_type, self._cb, queue_size=100)

    def _cb(self, msg):
        c = self.clock()
        with self.lock:
            self.items.append((c, time.monotonic(), msg))

    def since(self, mono):
        with self.lock:
            return [(c, m) for (c, t, m) in self.items if t >= mono]

    def wait(self, count, timeout, since=0.0):
        end = time.monotonic() + timeout
        while time.monotonic() < end and len(self.since(since)) < count:
            time.sleep(0.02)
        return self.since(since)


def check_behind(test, items, what, near, max_delay, ahead=1e-6):
    """(clock at arrival, message) pairs: each stamp at or behind the clock it arrived at, never
    ahead (by more than `ahead`: the clock as another node's messages show it to this test may
    lag what the node saw); behind by less than `near` at the median and `max_delay` at most (a
    loaded machine may delay a message's delivery). Prints the median and the largest."""
    for clock, m in items:
        stamp = m.header.stamp.to_sec()
        test.assertLessEqual(stamp, clock + ahead, "%s: stamp %.6f ahead of %.6f" %
                             (what, stamp, clock))
    lags = sorted(clock - m.header.stamp.to_sec() for clock, m in items)
    median = lags[len(lags) // 2]
    print("%s: stamp behind the clock at arrival: median %.4f s, max %.4f s" %
          (what, median, lags[-1]))
    test.assertLess(median, near, "%s: stamps behind the clock" % what)
    test.assertLess(lags[-1], max_delay, "%s: stamps behind the clock" % what)


class Node:
    """corde_sim_node named `name` with private parameters `args`, its output in a file."""

    def __init__(self, name, args):
        self.log = tempfile.NamedTemporaryFile(mode="w+", prefix="corde_time_", suffix=".log")
        cmd = [roslib.packages.find_node("corde_sim", "corde_sim_node")[0], "__name:=" + name]
        self.proc = subprocess.Popen(cmd + args, stdout=self.log, stderr=subprocess.STDOUT,
                                     start_new_session=True)

    def output(self):
        with open(self.log.name) as f:
            return f.read()

    def stop(self):
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGINT)
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
        self.log.close()
