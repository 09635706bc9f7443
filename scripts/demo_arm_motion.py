#!/usr/bin/python3
# (Debian's python3 on purpose: it has rospy and sensor_msgs.)
"""Slow, smooth joint motion for the demo arm (launch/robot_example.launch).

Waits for the first /joint_states to learn where the joints are, then publishes
sensor_msgs/JointState commands on `joint_command` (joint_state_publisher's source) at `~rate`:
each joint swings about its start value as amplitude * sin(2 pi t / period), faded in over the
first `~fade_in` seconds so that neither position nor velocity jumps. Starting from the measured
state rather than fixed numbers keeps the tool where the cable was placed.

Private parameters: rate (Hz, 50), fade_in (s, 3), amplitudes and periods (dictionaries by joint
name, rad and s; the defaults move the tool by +-14 cm sideways and +-8 cm in height;
periods default to 8 s).
"""
import math

import rospy
from sensor_msgs.msg import JointState

# Lift, elbow and wrist together raise and lower the tool (+-8 cm) keeping it pointing down.
AMPLITUDES = {"shoulder_pan": 0.35, "shoulder_lift": 0.07, "elbow": 0.20, "wrist_pitch": -0.27}
PERIODS = {"shoulder_pan": 12.0, "shoulder_lift": 8.0, "elbow": 8.0, "wrist_pitch": 8.0}


def fade(t, t_fade):
    """0 at t = 0 to 1 at t_fade, with zero slope at both ends."""
    if t >= t_fade:
        return 1.0
    return 0.5 - 0.5 * math.cos(math.pi * max(t, 0.0) / t_fade)


def main():
    rospy.init_node("demo_arm_motion")
    rate_hz = rospy.get_param("~rate", 50.0)
    t_fade = max(rospy.get_param("~fade_in", 3.0), 1e-3)
    amplitudes = rospy.get_param("~amplitudes", AMPLITUDES)
    periods = rospy.get_param("~periods", PERIODS)

    start = rospy.wait_for_message("joint_states", JointState)
    q0 = dict(zip(start.name, start.position))
    names = [n for n in amplitudes if n in q0]
    missing = sorted(set(amplitudes) - set(q0))
    if missing:
        rospy.logwarn("demo_arm_motion: joints not in joint_states, not moved: %s", missing)
    rospy.loginfo("demo_arm_motion: moving %s from %s", names, [round(q0[n], 3) for n in names])

    pub = rospy.Publisher("joint_command", JointState, queue_size=10)
    t0 = rospy.Time.now()
    rate = rospy.Rate(rate_hz)
    while not rospy.is_shutdown():
        now = rospy.Time.now()
        t = (now - t0).to_sec()
        f = fade(t, t_fade)
        msg = JointState()
        msg.header.stamp = now
        msg.name = names
        msg.position = [
            q0[n] + f * amplitudes[n] * math.sin(2.0 * math.pi * t / periods.get(n, 8.0))
            for n in names
        ]
        pub.publish(msg)
        try:
            rate.sleep()
        except rospy.ROSInterruptException:
            break


if __name__ == "__main__":
    main()
