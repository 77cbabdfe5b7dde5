#!/usr/bin/python3
"""A latched static transform as static_transform_publisher publishes it (Debian's ROS packages
do not ship that executable): static_mount.py x y z yaw pitch roll parent child. Stands in for a
URDF's robot_state_publisher in the rostests."""

import math
import sys

import rospy
import tf2_ros
from geometry_msgs.msg import TransformStamped


def main():
    args = rospy.myargv(sys.argv)[1:]
    x, y, z, yaw, pitch, roll = (float(a) for a in args[:6])
    t = TransformStamped()
    t.header.frame_id, t.child_frame_id = args[6], args[7]
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = x, y, z
    # q = qz(yaw) qy(pitch) qx(roll)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    t.transform.rotation.w = cr * cp * cy + sr * sp * sy
    t.transform.rotation.x = sr * cp * cy - cr * sp * sy
    t.transform.rotation.y = cr * sp * cy + sr * cp * sy
    t.transform.rotation.z = cr * cp * sy - sr * sp * cy
    rospy.init_node('static_mount', anonymous=True)
    broadcaster = tf2_ros.StaticTransformBroadcaster()
    broadcaster.sendTransform(t)
    rospy.spin()


if __name__ == '__main__':
    main()
