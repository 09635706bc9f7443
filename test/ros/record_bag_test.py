#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy, rosbag and the generated messages.)
"""Recording to a bag (record_bag.test): the launch's record:=true writes the node's rod_state and
the grasps' reaction wrenches to the bag, which python3-rosbag reads back."""
import os
import time
import unittest

import rosbag
import rospy
import rostest

WAIT = 60.0  # s: the 4 s recording closes its bag within this, on a loaded machine too


class RecordBag(unittest.TestCase):
    def test_bag_holds_rod_state_and_reactions(self):
        rospy.init_node("record_bag_test")
        path = rospy.get_param("~bag")
        self.addCleanup(lambda: os.path.exists(path) and os.remove(path))
        # rosbag record writes PATH.active while recording and renames it when done.
        end = time.monotonic() + WAIT
        while not os.path.exists(path) and time.monotonic() < end:
            time.sleep(0.2)
        self.assertTrue(os.path.exists(path), "no bag at %s after %.0f s" % (path, WAIT))
        states, reactions = [], []
        with rosbag.Bag(path) as bag:
            info = bag.get_type_and_topic_info().topics
            for topic, msg, _ in bag.read_messages():
                if topic == "/rod_state":
                    states.append(msg)
                elif topic == "/grasps/gripper/reaction":
                    reactions.append(msg)
        self.assertEqual(info["/rod_state"].msg_type, "corde_sim/WorldState")
        self.assertEqual(info["/grasps/gripper/reaction"].msg_type, "geometry_msgs/WrenchStamped")
        # state_rate 50 Hz for 4 s of wall time: far more than these, even slowed down.
        self.assertGreater(len(states), 20)
        self.assertGreater(len(reactions), 20)
        self.assertEqual(set(info), {"/rod_state", "/grasps/gripper/reaction"})
        cable = states[-1].rods[0]
        self.assertEqual(cable.name, "cable")
        self.assertEqual(len(cable.nodes), len(cable.orientations) + 1)
        times = [s.sim_time for s in states]
        self.assertEqual(times, sorted(times))
        self.assertGreater(times[-1] - times[0], 1.0)
        # The gripper carries half the cable's weight (0.28 N, default_reaction.test): the wrench
        # (in the holder's frame) is not zero.
        f = reactions[-1].wrench.force
        self.assertEqual(reactions[-1].header.frame_id, "grasp/gripper")
        self.assertGreater((f.x ** 2 + f.y ** 2 + f.z ** 2) ** 0.5, 0.1)


if __name__ == "__main__":
    rostest.rosrun("corde_sim", "record_bag", RecordBag)
