#!/usr/bin/python3
"""tracking_node + mapping_node + loop_closure_node on the rendered courtyard_loop (900 frames,
a 47 m loop, 30 Hz, simulated time):
- the loop: at least one Sim3Constraint between keyframes that truly see the same place (ground
  truth within 3 m), the mapping node's correcting MapUpdate carries it as a loop link, map -> odom
  is the identity before the correction and not after, the Path is republished with the whole
  corrected history;
- accuracy: the corrected trajectory (the final Path, every tracked frame) and the mapping node's
  keyframes (~save_trajectory) within 0.5% of the path (ATE after Sim(3) alignment, the loop
  closure issue's bound); the trajectory as tracked (tf at each image stamp) is printed;
- relocalisation over topics, then: the camera covered (black frames) and uncovered 20 m back
  along the loop (frames 300-359 again, later stamps): the tracker says it is lost and sends
  RelocalisationRequests, the loop closure node answers, tracking resumes within 5 frames, at the
  place it first tracked there.
"""

import copy
import os
import sys
import time
import unittest

import rospy
import rostest
import tf2_ros
from nav_msgs.msg import Path
from rosgraph_msgs.msg import Log
from scale_drift_slam.msg import (Keyframe, MapUpdate, RelocalisationAnswer, RelocalisationRequest,
                                  Sim3Constraint, TrackingStatus)
from scale_drift_slam.srv import SaveTrajectory
from sensor_msgs.msg import Image
from tf2_msgs.msg import TFMessage

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import sds_rostest as sds  # noqa: E402

FRAMES = 900
KIDNAP_FRAMES = (300, 60)  # frames 300-359 shown again after the bag
KIDNAP_START = 1040.0      # their new stamps (the bag ends at 1029.97 s)


def load_truth(folder):
    """The ground truth: (stamp, position, quaternion x y z w) of the camera in the world."""
    rows = [line.split() for line in open(os.path.join(folder, 'groundtruth.txt'))
            if line.strip() and not line.startswith('#')]
    return [(float(r[0]), tuple(float(v) for v in r[1:4]), tuple(float(v) for v in r[4:8]))
            for r in rows]


def nearest(rows, stamp):
    return min(rows, key=lambda row: abs(row[0] - stamp))


def distance(a, b):
    return sum((x - y) ** 2 for x, y in zip(a, b)) ** 0.5


def is_identity(t, tolerance=1e-9):
    tr, q = t.translation, t.rotation
    return max(abs(tr.x), abs(tr.y), abs(tr.z), abs(q.x), abs(q.y), abs(q.z)) < tolerance


class LoopClosure(unittest.TestCase):

    def setUp(self):
        self.rosout = sds.Rosout()
        self.buffer = tf2_ros.Buffer(cache_time=rospy.Duration(3600))
        tf2_ros.TransformListener(self.buffer)
        self.statuses, self.keyframes, self.constraints, self.updates = [], [], [], []
        self.requests, self.answers, self.paths, self.map_odom = [], [], [], []
        rospy.Subscriber('/tracking_status', TrackingStatus, self.statuses.append,
                         queue_size=1000)
        rospy.Subscriber('/keyframes', Keyframe,
                         lambda m: self.keyframes.append((m.id, m.header.stamp, m.session)),
                         queue_size=100)
        rospy.Subscriber('/loop_constraints', Sim3Constraint, self.constraints.append,
                         queue_size=10)
        rospy.Subscriber('/map_updates', MapUpdate, lambda m: self.updates.append(
            (m.header.stamp, m.has_loop_correction, list(zip(m.loop_link_from, m.loop_link_to)))),
            queue_size=100)
        rospy.Subscriber('/relocalisation_requests', RelocalisationRequest, self.requests.append,
                         queue_size=100)
        rospy.Subscriber('/relocalisation_answers', RelocalisationAnswer, self.answers.append,
                         queue_size=100)
        rospy.Subscriber('/path', Path, self.paths.append, queue_size=100)
        rospy.Subscriber('/tf', TFMessage, sds.map_odom_recorder(self.map_odom),
                         queue_size=1000)
        self.image_pub = rospy.Publisher('/camera/image_raw', Image, queue_size=100)
        rospy.wait_for_service('/mapping_node/save_trajectory', timeout=30)
        self.assertTrue(sds.wait_until(lambda: sds.node_pid('/loop_closure_node'), 30))
        self.assertTrue(sds.wait_until(lambda: self.image_pub.get_num_connections() > 0, 30))
        time.sleep(1.0)  # subscriptions connect

    def test_loop_and_relocalisation_on_courtyard(self):
        bag, folder = sds.render_bag('courtyard_loop', FRAMES)
        truth = load_truth(folder)
        groundtruth = os.path.join(folder, 'groundtruth.txt')
        start = time.time()
        sds.play_bag(bag)
        played = time.time() - start
        self.assertTrue(sds.wait_for_last_frame(self.statuses, folder),
                        '%d statuses for %d images' % (len(self.statuses), FRAMES))
        keyframes, updates = self.keyframes, self.updates
        sds.wait_until(lambda: keyframes and updates and updates[-1][0] >= keyframes[-1][1], 20)
        time.sleep(1.0)  # the loop node's last keyframes
        tracked = [s for s in self.statuses if s.has_pose]
        first = next(i for i, s in enumerate(self.statuses) if s.has_pose)
        self.assertEqual(len(tracked), len(self.statuses) - first, 'frames lost')

        # The loop: a verified constraint between two views of the same place.
        self.assertTrue(self.constraints,
                        'no Sim3Constraint published\n' + self.rosout.dump('loop_closure_node'))
        stamps = {k[0]: k[1].to_sec() for k in keyframes}
        loops = []
        for c in self.constraints:
            self.assertEqual(c.session, keyframes[-1][2])
            self.assertGreater(c.measurement.scale, 0.0)
            apart = distance(nearest(truth, stamps[c.from_keyframe_id])[1],
                             nearest(truth, stamps[c.to_keyframe_id])[1])
            self.assertLess(apart, 3.0, 'loop %d -> %d joins places %.1f m apart' % (
                c.from_keyframe_id, c.to_keyframe_id, apart))
            loops.append('%d -> %d (scale %.4f, %d inliers, %.2f px RMSE, truly %.2f m apart)' % (
                c.from_keyframe_id, c.to_keyframe_id, c.measurement.scale, c.inliers, c.rmse_px,
                apart))
        corrections = [u for u in updates if u[1]]
        self.assertTrue(corrections, 'the mapping node published no loop correction\n' +
                        self.rosout.dump('mapping_node'))
        c = self.constraints[0]
        self.assertIn((c.from_keyframe_id, c.to_keyframe_id), corrections[-1][2])
        corrected = self.rosout.find('mapping_node', 'corrected: sim3 graph')
        self.assertTrue(corrected)

        # map -> odom: the identity before the loop correction, not after.
        correction_stamp = corrections[0][0].to_sec()
        before = [t for stamp, t in self.map_odom if stamp < correction_stamp]
        self.assertGreater(len(before), 600)
        self.assertTrue(all(is_identity(t) for t in before))
        self.assertFalse(is_identity(self.map_odom[-1][1], 1e-6), self.map_odom[-1][1])

        # The path was republished with the corrected history right after the correction.
        final_path = self.paths[-1]
        self.assertGreaterEqual(len(final_path.poses), len(tracked) - 5)
        after = [p for p in self.paths if p.header.stamp.to_sec() >= correction_stamp]
        self.assertGreater(len(after[0].poses), 0.8 * len(final_path.poses))

        # Accuracy: the corrected trajectory, the keyframes, and the trajectory as tracked.
        path_ratio, path_report = sds.ate_ratio(groundtruth, sds.path_poses(final_path),
                                                'courtyard_corrected_path.txt')
        keyframe_file = os.path.join(sds.work_dir(), 'courtyard_keyframes.txt')
        answer = rospy.ServiceProxy('/mapping_node/save_trajectory', SaveTrajectory)(keyframe_file)
        self.assertTrue(answer.success, answer.message)
        keyframe_report = sds.evaluate(groundtruth, keyframe_file)
        keyframe_ratio = (keyframe_report['ate']['rmse'] /
                          keyframe_report['ground_truth_path_length'])
        as_tracked = []  # tf at each image stamp: the history as it was published, uncorrected
        for s in tracked:
            t = self.buffer.lookup_transform('map', 'camera_optical_frame',
                                             s.header.stamp).transform
            as_tracked.append((s.header.stamp.to_sec(),
                               (t.translation.x, t.translation.y, t.translation.z),
                               (t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w)))
        tracked_ratio, _ = sds.ate_ratio(groundtruth, as_tracked, 'courtyard_as_tracked.txt')
        t = self.map_odom[-1][1].translation
        print('courtyard_loop: played in %.1f s; %d of %d frames tracked; %d keyframes; loops: %s;'
              ' mapping node: %s; map -> odom at the end: t = (%.4f, %.4f, %.4f); ATE of the '
              'corrected path %.4f m = %.3f%% of %.1f m (%d poses), keyframes %.3f%%, as tracked '
              '(tf) %.3f%%' % (
                  played, len(tracked), len(self.statuses), len(keyframes), '; '.join(loops),
                  corrected[0][2], t.x, t.y, t.z, path_report['ate']['rmse'], 100 * path_ratio,
                  path_report['ground_truth_path_length'], path_report['ate']['count'],
                  100 * keyframe_ratio, 100 * tracked_ratio))
        self.assertLess(path_ratio, 0.005)
        self.assertLess(keyframe_ratio, 0.005)

        self.relocalise_kidnapped_camera(bag, final_path)
        for node in ('/tracking_node', '/mapping_node', '/loop_closure_node'):
            self.assertIsNotNone(sds.node_pid(node), node + ' died')
        self.assertFalse(self.rosout.find('', level=Log.ERROR))

    def relocalise_kidnapped_camera(self, bag, first_path):
        """Black frames (lost), then frames 300-359 again with new stamps: relocalised."""
        skip, count = KIDNAP_FRAMES
        images, _ = sds.read_images(bag, count=count, skip=skip)
        original = [i.header.stamp.to_sec() for i in images]
        black = copy.deepcopy(images[0])
        black.data = bytes(len(black.data))
        shown = [black] * 5 + images
        statuses_before = len(self.statuses)
        for k, image in enumerate(shown):
            msg = copy.copy(image)
            msg.header = copy.deepcopy(image.header)
            msg.header.stamp = rospy.Time.from_sec(KIDNAP_START + k / 30.0)
            self.image_pub.publish(msg)
            time.sleep(1.0 / 30)
        statuses = self.statuses
        self.assertTrue(sds.wait_until(lambda: len(statuses) >= statuses_before + len(shown), 20))
        kidnapped = self.statuses[statuses_before:]
        self.assertTrue([s for s in kidnapped if s.state == TrackingStatus.LOST],
                        'the tracker did not say it was lost')
        self.assertTrue(self.requests, 'no relocalisation request')
        self.assertTrue(all(r.image.encoding == 'mono8' and r.session == kidnapped[-1].session
                            for r in self.requests))
        found = [a for a in self.answers if a.success]
        self.assertTrue(found, [a.reason for a in self.answers])
        back = KIDNAP_START + 5 / 30.0  # the first image after the black frames
        resumed = next(s for s in kidnapped if s.has_pose)
        frames = round((resumed.header.stamp.to_sec() - back) * 30.0)
        self.assertLessEqual(frames, 5)
        self.assertTrue(all(s.has_pose for s in kidnapped
                            if s.header.stamp > resumed.header.stamp), 'lost again')
        # Where it tracked these images the first time (the corrected path) and now (tf).
        first = {round(p.header.stamp.to_sec(), 3): p.pose.position for p in first_path.poses}
        errors = []
        for k, stamp in enumerate(original):
            again = rospy.Time.from_sec(KIDNAP_START + (k + 5) / 30.0)
            if again < resumed.header.stamp or round(stamp, 3) not in first:
                continue
            t = self.buffer.lookup_transform('map', 'camera_link', again).transform.translation
            p = first[round(stamp, 3)]
            errors.append(distance((t.x, t.y, t.z), (p.x, p.y, p.z)))
        extent = max(distance((p.pose.position.x, p.pose.position.y, p.pose.position.z),
                              (0.0, 0.0, 0.0)) for p in first_path.poses)
        print('kidnapped camera: lost, %d relocalisation requests, %d answers (%d successful: '
              'keyframe %d, %d inliers), tracking resumed %d frames after the image came back; '
              'position against the first pass: median %.4f, max %.4f (map extent %.2f)' % (
                  len(self.requests), len(self.answers), len(found), found[0].keyframe_id,
                  found[0].inliers, frames, sorted(errors)[len(errors) // 2], max(errors),
                  extent))
        self.assertGreater(len(errors), 40)
        self.assertLess(max(errors), 0.01 * extent)


if __name__ == '__main__':
    rospy.init_node('test_loop_closure')
    rostest.rosrun('scale_drift_slam', 'loop_closure', LoopClosure)
