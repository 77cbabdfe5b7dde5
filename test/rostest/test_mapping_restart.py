#!/usr/bin/python3
"""The mapping node killed (SIGKILL) in the middle of a bag and restarted by roslaunch: tracking
goes on publishing tf meanwhile, the new mapping node builds a new map from the following
keyframes, the tracker and the loop closure node apply its map updates (continuing above their own
map versions), and the trajectory from tf stays within 1% of the path."""

import os
import sys
import time
import unittest

import rospy
import rostest
import tf2_ros
from rosgraph_msgs.msg import Log
from scale_drift_slam.msg import Keyframe, MapUpdate, TrackingStatus
from sensor_msgs.msg import PointCloud2
from tf2_msgs.msg import TFMessage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import sds_rostest as sds  # noqa: E402

FRAMES = 300


class MappingRestart(unittest.TestCase):

    def test_mapping_node_killed_and_restarted(self):
        rosout = sds.Rosout()
        bag, folder = sds.render_bag('office_orbit', FRAMES)
        buffer = tf2_ros.Buffer(cache_time=rospy.Duration(3600))
        tf2_ros.TransformListener(buffer)
        statuses, keyframes, updates, clouds, tf_wall = [], [], [], [], []
        rospy.Subscriber('/tracking_status', TrackingStatus, statuses.append, queue_size=1000)
        rospy.Subscriber('/keyframes', Keyframe, keyframes.append, queue_size=100)
        rospy.Subscriber('/map_updates', MapUpdate, updates.append, queue_size=100)
        rospy.Subscriber('/map_cloud', PointCloud2,
                         lambda m: clouds.append((time.time(), m.width * m.height)), queue_size=100)

        def on_tf(msg):
            if any(t.child_frame_id == 'base_link' for t in msg.transforms):
                tf_wall.append(time.time())
        rospy.Subscriber('/tf', TFMessage, on_tf, queue_size=1000)
        rospy.wait_for_service('/mapping_node/save_trajectory', timeout=30)
        rospy.wait_for_service('/tracking_node/reset', timeout=30)
        tracking_pid = sds.node_pid('/tracking_node')
        loop_pid = sds.node_pid('/loop_closure_node')
        self.assertIsNotNone(loop_pid)
        time.sleep(1.0)

        player = sds.play_bag(bag, rate=0.5, wait=False)
        # Kill the mapper a third into the bag, once it has answered a few keyframes.
        self.assertTrue(sds.wait_until(
            lambda: len(updates) >= 3 and statuses and statuses[-1].header.stamp.to_sec() > 1003.0,
            60))
        first_mapper = updates[-1].mapper_id
        killed_pid = sds.kill_node('/mapping_node')
        killed = time.time()
        self.assertTrue(sds.wait_until(
            lambda: sds.node_pid('/mapping_node') not in (None, killed_pid), 30),
            'mapping_node was not restarted')
        restarted = time.time()
        tf_while_down = sum(1 for t in tf_wall if killed < t < restarted)
        self.assertGreater(tf_while_down, 5, 'no tf while the mapping node was down')

        player.wait()
        self.assertTrue(sds.wait_for_last_frame(statuses, folder))
        self.assertEqual(sds.missing_frames(statuses, folder), '')
        sds.wait_until(lambda: updates and keyframes and
                       updates[-1].header.stamp == keyframes[-1].header.stamp, 20)

        # The new mapper answered, with its own id and versions, and the tracker applied them.
        new_updates = [u for u in updates if u.mapper_id != first_mapper]
        self.assertGreaterEqual(len(new_updates), 3)
        self.assertEqual(len(set(u.session for u in updates)), 1)
        self.assertTrue(rosout.wait_for('tracking_node', 'new mapper', level=Log.WARN),
                        rosout.dump('tracking_node'))
        self.assertTrue(rosout.wait_for('loop_closure_node', 'new mapper', level=Log.WARN),
                        rosout.dump('loop_closure_node'))
        applied = statuses[-1].map_version
        self.assertGreaterEqual(applied, new_updates[0].map_version)
        self.assertLessEqual(applied, new_updates[-1].map_version)
        self.assertGreater(clouds[-1][1], 0)
        self.assertTrue(any(t > restarted for t, _ in clouds))

        # Tracking never stopped: every frame after initialisation has a pose, none lost.
        first = next(i for i, s in enumerate(statuses) if s.has_pose)
        tracked = [s for s in statuses if s.has_pose]
        self.assertEqual(len(tracked), len(statuses) - first)
        self.assertFalse([s for s in statuses if s.state == TrackingStatus.LOST])
        self.assertEqual(sds.node_pid('/tracking_node'), tracking_pid)
        self.assertEqual(sds.node_pid('/loop_closure_node'), loop_pid)

        poses = []
        for s in tracked:
            t = buffer.lookup_transform('map', 'camera_optical_frame', s.header.stamp)
            tr, q = t.transform.translation, t.transform.rotation
            poses.append((s.header.stamp.to_sec(), (tr.x, tr.y, tr.z), (q.x, q.y, q.z, q.w)))
        estimate = os.path.join(sds.work_dir(), 'restart_from_tf.txt')
        sds.write_tum(estimate, poses)
        report = sds.evaluate(os.path.join(folder, 'groundtruth.txt'), estimate)
        ratio = report['ate']['rmse'] / report['ground_truth_path_length']
        print('mapping node down for %.1f s (tf messages meanwhile: %d); %d updates of the new '
              'mapper; tracker at map version %d; ATE from tf %.3f%% of the path' % (
                  restarted - killed, tf_while_down, len(new_updates), applied, 100 * ratio))
        self.assertLess(ratio, 0.01)


if __name__ == '__main__':
    rospy.init_node('test_mapping_restart')
    rostest.rosrun('scale_drift_slam', 'mapping_restart', MappingRestart)
