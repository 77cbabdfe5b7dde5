#!/usr/bin/python3
"""tf on a robot (REP 105, issue 19) on the first 300 frames of the rendered courtyard_loop:
- "urdf": a static base -> camera mount (a URDF's robot_state_publisher stands in for it); the
  node reads it from tf (publishes none of its own) and publishes map -> odom -> base: the
  camera's pose in map through that tree is the tracker's (its Path) at every tracked frame;
  nav_msgs/Odometry of the base in odom equals tf, with a known, positive definite covariance
  and the twist of consecutive poses.
- "wheel": the robot's odometry owns odom -> base (this test publishes the ground-truth motion
  of the base, in metres, from another origin); the node publishes only map -> odom, and the
  camera's pose in map through the robot's odometry is the tracker's; Odometry in map. Where
  the robot's odometry is missing (its last 30 frames) no map -> odom is published, the node
  warns and keeps tracking.
"""

import math
import os
import sys
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry, Path
from rosgraph_msgs.msg import Clock, Log
from scale_drift_slam.msg import TrackingStatus
from tf2_msgs.msg import TFMessage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import sds_rostest as sds  # noqa: E402

FRAMES = 300
MISSING_ODOMETRY = 30  # the wheel odometry's last frames that are never published
R_BODY_OPTICAL = np.array([[0, 0, 1], [-1, 0, 0], [0, -1, 0]], float)


def rpy_matrix(roll, pitch, yaw):
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    return rz.dot(ry).dot(rx)


def matrix(rotation, translation):
    T = np.eye(4)
    T[:3, :3] = rotation
    T[:3, 3] = translation
    return T


def quat_matrix(x, y, z, w):
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def matrix_quat(R):
    w = math.sqrt(max(0.0, 1 + R[0, 0] + R[1, 1] + R[2, 2])) / 2
    x = math.copysign(math.sqrt(max(0.0, 1 + R[0, 0] - R[1, 1] - R[2, 2])) / 2, R[2, 1] - R[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1 - R[0, 0] + R[1, 1] - R[2, 2])) / 2, R[0, 2] - R[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1 - R[0, 0] - R[1, 1] + R[2, 2])) / 2, R[1, 0] - R[0, 1])
    return x, y, z, w


def from_transform(t):
    r, p = t.rotation, t.translation
    return matrix(quat_matrix(r.x, r.y, r.z, r.w), (p.x, p.y, p.z))


def from_pose(p):
    q, t = p.orientation, p.position
    return matrix(quat_matrix(q.x, q.y, q.z, q.w), (t.x, t.y, t.z))


def difference(A, B):
    """(translation distance, rotation angle) between two 4x4 poses."""
    R = A[:3, :3].T.dot(B[:3, :3])
    angle = math.acos(max(-1.0, min(1.0, (np.trace(R) - 1) / 2)))
    return np.linalg.norm(A[:3, 3] - B[:3, 3]), angle


# The mounts of robot_tf.test (base -> camera body) and the origin of the wheel odometry.
URDF_MOUNT = matrix(rpy_matrix(0.02, 0.35, -0.1), (0.3, 0.05, 0.8))
WHEEL_MOUNT = matrix(rpy_matrix(0.0, 0.2, 0.1), (-0.2, 0.0, 1.1))
T_ODOM_WORLD = matrix(rpy_matrix(0.0, 0.0, 0.7), (5.0, -2.0, 0.3))


class WheelOdometry(object):
    """Publishes wheel_odom -> wheel_base_link: the ground truth of the rendered sequence (the
    optical camera in the world) carried to the base by the mount, from another origin; each
    pose at its image's stamp, a little ahead of the clock (as a robot's odometry at a higher
    rate would be there). The odometry stops `missing` frames before the sequence ends: the
    node cannot look it up at those images' stamps."""

    def __init__(self, folder, missing):
        self.poses = []
        T_base_optical = WHEEL_MOUNT.dot(matrix(R_BODY_OPTICAL, (0, 0, 0)))
        for line in open(os.path.join(folder, 'groundtruth.txt')):
            if not line.strip() or line[0] == '#':
                continue
            v = [float(x) for x in line.split()]
            T_world_optical = matrix(quat_matrix(*v[4:8]), v[1:4])
            self.poses.append((v[0], T_ODOM_WORLD.dot(T_world_optical).dot(
                np.linalg.inv(T_base_optical))))
        self.poses = self.poses[:-missing]
        self.last_stamp = self.poses[-1][0]
        self.next = 0
        self.lock = threading.Lock()
        self.broadcaster = tf2_ros.TransformBroadcaster()
        rospy.Subscriber('/clock', Clock, self.on_clock, queue_size=10)

    def on_clock(self, msg):
        now = msg.clock.to_sec()
        with self.lock:
            out = []
            while self.next < len(self.poses) and self.poses[self.next][0] <= now + 0.2:
                stamp, T = self.poses[self.next]
                t = TransformStamped()
                t.header.stamp = rospy.Time.from_sec(stamp)
                t.header.frame_id, t.child_frame_id = 'wheel_odom', 'wheel_base_link'
                t.transform.translation.x, t.transform.translation.y, \
                    t.transform.translation.z = T[:3, 3]
                (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
                 t.transform.rotation.w) = matrix_quat(T[:3, :3])
                out.append(t)
                self.next += 1
            if out:
                self.broadcaster.sendTransform(out)


class RobotTf(unittest.TestCase):

    def setUp(self):
        self.rosout = sds.Rosout()
        self.buffer = tf2_ros.Buffer(cache_time=rospy.Duration(3600))
        self.listener = tf2_ros.TransformListener(self.buffer)
        self.tf = []  # (publisher, parent, child, stamp)
        self.statuses = {'urdf': [], 'wheel': []}
        self.odometry = {'urdf': [], 'wheel': []}
        self.paths = {'urdf': [], 'wheel': []}
        for ns in ('urdf', 'wheel'):
            rospy.Subscriber('/%s/tracking_status' % ns, TrackingStatus,
                             self.statuses[ns].append, queue_size=1000)
            rospy.Subscriber('/%s/odometry' % ns, Odometry, self.odometry[ns].append,
                             queue_size=1000)
            rospy.Subscriber('/%s/path' % ns, Path, self.paths[ns].append, queue_size=10)
        rospy.Subscriber('/tf', TFMessage, self.on_tf, queue_size=1000)
        self.tf_static = []  # (publisher, parent, child): latched, so also what came before
        rospy.Subscriber('/tf_static', TFMessage, self.on_tf_static, queue_size=100)
        for ns in ('urdf', 'wheel'):
            rospy.wait_for_service('/%s/tracking_node/reset' % ns, timeout=30)
        time.sleep(1.0)  # subscriptions connect

    def on_tf_static(self, msg):
        caller = msg._connection_header['callerid']
        for t in msg.transforms:
            self.tf_static.append((caller, t.header.frame_id, t.child_frame_id))

    def on_tf(self, msg):
        caller = msg._connection_header['callerid']
        for t in msg.transforms:
            self.tf.append((caller, t.header.frame_id, t.child_frame_id, t.header.stamp))

    def tracked(self, ns, folder):
        """The tracked frames' stamps, and the camera body pose in map of each (the node's Path,
        matched by stamp)."""
        statuses = [s for s in self.statuses[ns] if s.has_pose]
        first = next(i for i, s in enumerate(self.statuses[ns]) if s.has_pose)
        after = len(self.statuses[ns]) - first
        self.assertGreaterEqual(len(statuses), 0.9 * after, '%s: %d of %d frames tracked' % (
            ns, len(statuses), after))
        path = {round(p.header.stamp.to_sec(), 6): from_pose(p.pose) for p in
                self.paths[ns][-1].poses}
        # The Path is published every 5 frames: the last few frames may not be in it.
        matched = [(s.header.stamp, path[round(s.header.stamp.to_sec(), 6)]) for s in statuses
                   if round(s.header.stamp.to_sec(), 6) in path]
        self.assertGreaterEqual(len(matched), len(statuses) - 5)
        return matched

    def check_camera_in_map(self, ns, tracked, stamps=None):
        """tf map -> camera body at each stamp against the tracker's pose; the worst error."""
        worst = (0.0, 0.0)
        checked = 0
        for stamp, T_map_camera in tracked:
            if stamps is not None and stamp not in stamps:
                continue
            T = from_transform(self.buffer.lookup_transform(
                '%s_map' % ns, '%s_camera_link' % ns, stamp).transform)
            d = difference(T, T_map_camera)
            worst = (max(worst[0], d[0]), max(worst[1], d[1]))
            checked += 1
        self.assertLess(worst[0], 1e-5, ns)
        self.assertLess(worst[1], 1e-5, ns)
        return worst, checked

    def check_odometry(self, ns, parent, stamps=None):
        """Odometry against tf, its covariance; the known ones' position sigmas."""
        known, checked = [], 0
        for msg in self.odometry[ns]:
            if stamps is not None and msg.header.stamp not in stamps:
                continue
            checked += 1
            self.assertEqual((msg.header.frame_id, msg.child_frame_id),
                             ('%s_%s' % (ns, parent), '%s_base_link' % ns))
            T_tf = from_transform(self.buffer.lookup_transform(
                msg.header.frame_id, msg.child_frame_id, msg.header.stamp).transform)
            d = difference(from_pose(msg.pose.pose), T_tf)
            self.assertLess(d[0], 1e-5)
            self.assertLess(d[1], 1e-5)
            covariance = np.array(msg.pose.covariance).reshape(6, 6)
            self.assertLess(np.abs(covariance - covariance.T).max(), 1e-9 * np.abs(covariance).max())
            self.assertGreater(np.linalg.eigvalsh(covariance).min(), 0.0)
            if covariance.max() < 1e3:
                known.append(math.sqrt(covariance[:3, :3].trace()))
                # The base's position: millimetres to centimetres of a scene of metres.
                self.assertLess(known[-1], 0.1, covariance)
        self.assertGreaterEqual(len(known), 0.9 * checked)
        self.assertGreater(len(known), 100)
        return known

    def check_twist(self, ns):
        """The twist (child axes) integrates to the next pose: R^T (p_k - p_k-1) = v dt."""
        checked = 0
        odometry = self.odometry[ns]
        for a, b in zip(odometry, odometry[1:]):
            dt = (b.header.stamp - a.header.stamp).to_sec()
            if not 0 < dt < 0.1:
                continue
            A, B = from_pose(a.pose.pose), from_pose(b.pose.pose)
            step = B[:3, :3].T.dot(B[:3, 3] - A[:3, 3])
            v = b.twist.twist.linear
            self.assertLess(np.linalg.norm(step - dt * np.array([v.x, v.y, v.z])),
                            1e-6 + 1e-6 * np.linalg.norm(step))
            checked += 1
        self.assertGreater(checked, 0.8 * len(odometry))

    def test_robot_tf(self):
        bag, folder = sds.render_bag('courtyard_loop', FRAMES)
        odometry = WheelOdometry(folder, MISSING_ODOMETRY)
        sds.play_bag(bag, rate=0.5)
        for ns in ('urdf', 'wheel'):
            self.assertTrue(sds.wait_for_last_frame(self.statuses[ns], folder),
                            '%s: %d statuses' % (ns, len(self.statuses[ns])))
        time.sleep(1.0)
        # The mount came from tf: the node's own static transform is only camera -> optical.
        for ns in ('urdf', 'wheel'):
            self.assertEqual(
                set((p, c) for caller, p, c in self.tf_static if c == '%s_camera_link' % ns),
                {('%s_base_link' % ns, '%s_camera_link' % ns)})
            self.assertEqual(
                set((p, c) for caller, p, c in self.tf_static
                    if caller == '/%s/tracking_node' % ns),
                {('%s_camera_link' % ns, '%s_camera_optical_frame' % ns)}, self.tf_static)
            self.assertEqual(set(caller for caller, p, c in self.tf_static
                                 if c == '%s_camera_link' % ns), {'/%s_mount' % ns})

        # urdf: map -> odom -> base from our node, base -> camera only from the mount.
        urdf = self.tracked('urdf', folder)
        ours = set((p, c) for caller, p, c, _ in self.tf if caller == '/urdf/tracking_node')
        self.assertEqual(ours, {('urdf_map', 'urdf_odom'), ('urdf_odom', 'urdf_base_link')})
        urdf_worst, urdf_checked = self.check_camera_in_map('urdf', urdf)
        urdf_known = self.check_odometry('urdf', 'odom')
        self.check_twist('urdf')

        # wheel: only map -> odom from our node, at (nearly) every tracked frame; odom -> base
        # only from the robot's odometry.
        wheel = self.tracked('wheel', folder)
        ours = [(p, c, s) for caller, p, c, s in self.tf if caller == '/wheel/tracking_node']
        self.assertEqual(set((p, c) for p, c, _ in ours), {('wheel_map', 'wheel_odom')})
        others = set(caller for caller, p, c, _ in self.tf if c == 'wheel_base_link')
        self.assertEqual(others, {rospy.get_name()})
        map_odom_stamps = set(s for _, _, s in ours)
        # Where the robot's odometry is there, map -> odom is too; where it is missing (the last
        # frames) none is published, a warning says why, and the node carries on.
        with_odometry = [f for f in wheel if f[0].to_sec() <= odometry.last_stamp + 1e-6]
        self.assertLessEqual(len(with_odometry), len(wheel) - MISSING_ODOMETRY + 5)
        self.assertGreaterEqual(len(map_odom_stamps), 0.95 * len(with_odometry))
        self.assertFalse([s for s in map_odom_stamps if s.to_sec() > odometry.last_stamp + 1e-6])
        self.assertTrue(self.rosout.find('/wheel/tracking_node', 'no wheel_odom -> wheel_base_link',
                                         'not published', level=Log.WARN),
                        self.rosout.dump('/wheel/tracking_node'))
        self.assertEqual(self.statuses['wheel'][-1].header.stamp.to_sec(),
                         self.statuses['urdf'][-1].header.stamp.to_sec())
        wheel_worst, wheel_checked = self.check_camera_in_map('wheel', wheel, map_odom_stamps)
        self.assertGreaterEqual(wheel_checked, 0.95 * len(with_odometry))
        wheel_known = self.check_odometry('wheel', 'map', map_odom_stamps)
        # The map is not in metres: map -> odom moves while the robot drives.
        first, last = sorted(map_odom_stamps)[0], sorted(map_odom_stamps)[-1]
        drift = difference(
            from_transform(self.buffer.lookup_transform('wheel_map', 'wheel_odom', first).transform),
            from_transform(self.buffer.lookup_transform('wheel_map', 'wheel_odom', last).transform))
        slam_length = sum(np.linalg.norm(b[1][:3, 3] - a[1][:3, 3]) for a, b in zip(urdf, urdf[1:]))
        rows = [[float(x) for x in l.split()] for l in open(os.path.join(folder, 'groundtruth.txt'))
                if l.strip() and l[0] != '#']
        true_length = sum(np.linalg.norm(np.array(b[1:4]) - np.array(a[1:4]))
                          for a, b in zip(rows, rows[1:]))
        print('robot_tf: urdf %d frames tracked, camera in map through map->odom->base->camera '
              'within %.2g units / %.2g rad of the tracker (%d checked), %d odometry messages '
              'with a known covariance, position sigma median %.4f units (%.4f-%.4f); wheel %d '
              'frames tracked (%d with odometry), map->odom at %d, camera in map through the robot\'s odometry '
              'within %.2g units / %.2g rad (%d checked), %d known covariances; map->odom moved '
              '%.2f units / %.3f rad over the run; camera path %.2f map units for %.2f m (%.3f m '
              'per map unit)' % (
                  len(urdf), urdf_worst[0], urdf_worst[1], urdf_checked, len(urdf_known),
                  np.median(urdf_known), min(urdf_known), max(urdf_known), len(wheel),
                  len(with_odometry), len(map_odom_stamps), wheel_worst[0], wheel_worst[1], wheel_checked,
                  len(wheel_known), drift[0], drift[1], slam_length, true_length,
                  true_length / slam_length))
        for ns in ('urdf', 'wheel'):
            self.assertIsNotNone(sds.node_pid('/%s/tracking_node' % ns))
        self.assertFalse(self.rosout.find('tracking_node', level=Log.ERROR))


if __name__ == '__main__':
    rospy.init_node('test_robot_tf')
    rostest.rosrun('scale_drift_slam', 'robot_tf', RobotTf)
