#!/usr/bin/python3
"""Bad input does not take a node down, and each node says what is wrong: images before any
CameraInfo, a NaN CameraInfo, an unsupported encoding, time jumping backwards (the tracker and
then the map restart), invalid parameters at start-up (the node exits at once naming the
parameter); between the nodes: keyframes without an image or with a colour one (the loop closure
node stores them without a loop search), loop constraints with a non-positive scale, naming
unknown keyframes or of another session (the mapping node refuses them), a relocalisation request
without an image (answered with the reason); same-session keyframes with a zero or NaN camera
matrix, a pose at 1e9, 50 000 observations or an id far ahead of the tracker (refused, not in the
mapping node's keyframes, the real keyframe with that id taken afterwards). Also: every common
encoding and compressed images are tracked."""

import copy
import os
import subprocess
import sys
import time
import unittest

import rospy
import rostest
from rosgraph_msgs.msg import Log
from scale_drift_slam.msg import (Keyframe, MapUpdate, Observation, RelocalisationAnswer, RelocalisationRequest,
                                  Sim3Constraint, TrackingStatus)
from sensor_msgs.msg import CameraInfo, CompressedImage, Image
from scale_drift_slam.srv import SaveTrajectory
from std_srvs.srv import Trigger

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import sds_rostest as sds  # noqa: E402


def restamp(msg, stamp):
    msg.header.stamp = rospy.Time.from_sec(stamp)
    return msg


class BadInput(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        cls.rosout = sds.Rosout()
        bag, _ = sds.render_bag('office_orbit', 300)
        cls.images, cls.info = sds.read_images(bag, count=90)
        cls.statuses = []
        cls.compressed_statuses = []
        cls.keyframes = []
        cls.updates = []
        rospy.Subscriber('/tracking_status', TrackingStatus, cls.statuses.append, queue_size=1000)
        rospy.Subscriber('/compressed/tracking_status', TrackingStatus,
                         cls.compressed_statuses.append, queue_size=1000)
        rospy.Subscriber('/keyframes', Keyframe, cls.keyframes.append, queue_size=100)
        rospy.Subscriber('/map_updates', MapUpdate, cls.updates.append, queue_size=100)
        cls.image_pub = rospy.Publisher('/camera/image_raw', Image, queue_size=100)
        cls.info_pub = rospy.Publisher('/camera/camera_info', CameraInfo, queue_size=10,
                                       latch=True)
        cls.compressed_pub = rospy.Publisher('/compressed_camera/image/compressed',
                                             CompressedImage, queue_size=100)
        cls.compressed_info_pub = rospy.Publisher('/compressed_camera/camera_info', CameraInfo,
                                                  queue_size=10, latch=True)
        for pub in (cls.image_pub, cls.info_pub, cls.compressed_pub, cls.compressed_info_pub):
            assert sds.wait_until(lambda: pub.get_num_connections() > 0, 30), pub.name
        time.sleep(0.5)

    def publish(self, images, encodings=('mono8',), stamp_offset=0.0):
        for i, image in enumerate(images):
            msg = sds.reencode(image, encodings[i % len(encodings)])
            restamp(msg, image.header.stamp.to_sec() + stamp_offset)
            self.image_pub.publish(msg)
            time.sleep(1.0 / 30)

    def assertAlive(self, *nodes):
        for node in nodes:
            self.assertIsNotNone(sds.node_pid(node), node + ' died')

    def test_1_runtime_bad_input(self):
        rosout = self.rosout
        # Images before any CameraInfo: dropped, with the reason.
        self.publish(self.images[:3], stamp_offset=-100.0)
        self.assertTrue(rosout.wait_for('tracking_node', 'waiting for a valid CameraInfo',
                                        level=Log.WARN), rosout.dump('tracking_node'))
        # A CameraInfo with NaN: refused, with the reason.
        nan_info = CameraInfo()
        nan_info.header = self.info.header
        nan_info.width, nan_info.height = self.info.width, self.info.height
        nan_info.distortion_model, nan_info.D = self.info.distortion_model, self.info.D
        nan_info.K = list(self.info.K)
        nan_info.K[0] = float('nan')
        self.info_pub.publish(nan_info)
        self.assertTrue(rosout.wait_for('tracking_node', 'ignoring the CameraInfo',
                                        level=Log.ERROR), rosout.dump('tracking_node'))
        self.publish(self.images[3:5], stamp_offset=-100.0)
        self.assertEqual(self.statuses, [])
        # A valid CameraInfo, then an encoding the tracker cannot read.
        self.info_pub.publish(self.info)
        self.assertTrue(rosout.wait_for('tracking_node', 'camera: plumb_bob'))
        float_image = sds.reencode(self.images[5], 'mono8')
        float_image.encoding = '32FC1'
        float_image.step *= 4
        float_image.data = bytes(len(float_image.data) * 4)
        self.image_pub.publish(restamp(float_image, 950.0))
        self.assertTrue(rosout.wait_for('tracking_node', "unsupported image encoding '32FC1'",
                                        level=Log.ERROR), rosout.dump('tracking_node'))
        self.assertEqual(self.statuses, [])

        # Every common encoding is tracked: mono8, bgr8, rgb8, bgra8, mono16 in turn.
        self.publish(self.images, ('mono8', 'bgr8', 'rgb8', 'bgra8', 'mono16'))
        self.assertTrue(sds.wait_until(lambda: len(self.statuses) >= len(self.images), 20))
        self.assertFalse([s.message for s in self.statuses if s.rejected])
        self.assertEqual(self.statuses[-1].state, TrackingStatus.GOOD, self.statuses[-1])
        self.assertTrue(sds.wait_until(lambda: len(self.updates) >= 2, 10))
        session = self.statuses[-1].session

        # The bag restarts: time jumps back; the tracker resets, the mapper starts a new map.
        self.publish(self.images[:60])
        self.assertTrue(rosout.wait_for('tracking_node', 'time jumped backwards',
                                        level=Log.WARN), rosout.dump('tracking_node'))
        self.assertTrue(sds.wait_until(lambda: len(self.statuses) >= len(self.images) + 60, 20))
        restarted = self.statuses[len(self.images):]
        self.assertTrue(all(s.session != session for s in restarted))
        self.assertEqual(restarted[-1].state, TrackingStatus.GOOD, restarted[-1])
        self.assertTrue(rosout.wait_for('mapping_node', 'new tracker session', level=Log.WARN),
                        rosout.dump('mapping_node'))
        self.assertTrue(rosout.wait_for('loop_closure_node', 'new loop closer',
                                        'new tracker session', level=Log.WARN),
                        rosout.dump('loop_closure_node'))
        self.assertTrue(sds.wait_until(
            lambda: self.updates[-1].session == restarted[-1].session, 10))
        new_keyframes = [k for k in self.keyframes if k.session == restarted[-1].session]
        self.assertEqual(new_keyframes[0].id, 0)
        self.assertAlive('/tracking_node', '/mapping_node', '/loop_closure_node')

        # Both nodes reset on request and say so.
        for node in ('/tracking_node', '/mapping_node'):
            answer = rospy.ServiceProxy(node + '/reset', Trigger)()
            self.assertTrue(answer.success, answer.message)
            self.assertTrue(rosout.wait_for(node, '~reset was called', level=Log.WARN))
        self.assertAlive('/tracking_node', '/mapping_node')
        print('warnings and errors the nodes logged:')
        for name, level, text in rosout.find('', level=Log.WARN):
            print('  %s [%s] %s' % (name, {Log.WARN: 'WARN', Log.ERROR: 'ERROR'}.get(level), text))

    def test_2_compressed_images(self):
        self.compressed_info_pub.publish(self.info)
        time.sleep(0.5)
        for image in self.images[:60]:
            msg = CompressedImage()
            msg.header = image.header
            msg.format = 'mono8; png compressed'
            msg.data = sds.png(bytes(image.data), image.width, image.height)
            self.compressed_pub.publish(msg)
            time.sleep(1.0 / 30)
        self.assertTrue(sds.wait_until(lambda: len(self.compressed_statuses) >= 60, 20))
        self.assertFalse([s.message for s in self.compressed_statuses if s.rejected])
        self.assertEqual(self.compressed_statuses[-1].state, TrackingStatus.GOOD)
        self.assertAlive('/compressed/tracking_node')

    def test_3_invalid_parameters_stop_the_node_at_start(self):
        nan_calibration = os.path.join(sds.work_dir(), 'nan_calibration.yaml')
        with open(nan_calibration, 'w') as f:
            f.write('width: 640\nheight: 480\nfx: .nan\nfy: 500\ncx: 320\ncy: 240\n'
                    'distortion_model: plumb_bob\ndistortion: [0, 0, 0, 0, 0]\n')
        cases = [
            ('tracking_node', '_calibration_file:=' + nan_calibration, '~calibration_file'),
            ('tracking_node', '_tracker/good_inliers:=-3', 'good_inliers'),
            ('tracking_node', '_image_queue_size:=many', '~image_queue_size: must be an int'),
            ('tracking_node', '_config:=/nonexistent.yaml', '~config'),
            ('mapping_node', '_window_ba/window_size:=0', 'window_size'),
            ('loop_closure_node', '_loop_verification/max_scale:=-2', 'max_scale'),
            ('loop_closure_node', '_place_recognition/appearance/max_features:=many',
             'appearance.max_features'),
        ]
        for i, (node, argument, expected) in enumerate(cases):
            started = time.time()
            run = subprocess.run([sds.tool(node), '__name:=bad_%d' % i, argument],
                                 stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=30)
            output = run.stdout.decode(errors='replace')
            self.assertEqual(run.returncode, 1, output)
            self.assertIn('invalid parameter', output)
            self.assertIn(expected, output)
            self.assertLess(time.time() - started, 10)
        self.assertAlive('/tracking_node', '/mapping_node', '/loop_closure_node')

    def test_4_bad_messages_between_the_nodes(self):
        rosout = self.rosout
        answers = []
        rospy.Subscriber('/relocalisation_answers', RelocalisationAnswer, answers.append,
                         queue_size=10)
        keyframe_pub = rospy.Publisher('/keyframes', Keyframe, queue_size=10)
        constraint_pub = rospy.Publisher('/loop_constraints', Sim3Constraint, queue_size=10)
        request_pub = rospy.Publisher('/relocalisation_requests', RelocalisationRequest,
                                      queue_size=10)
        for pub, subscribers in ((keyframe_pub, 2), (constraint_pub, 1), (request_pub, 1)):
            assert sds.wait_until(lambda: pub.get_num_connections() >= subscribers, 30), pub.name
        time.sleep(0.5)

        # Keyframes of a new session: without an image, then with a colour image.
        session = 4242
        for i, image in enumerate((None, sds.reencode(self.images[0], 'rgb8'))):
            keyframe = Keyframe()
            keyframe.header.stamp = rospy.Time.from_sec(2000.0 + i)
            keyframe.session, keyframe.id = session, i
            keyframe.T_kf_world.orientation.w = 1.0
            keyframe.camera = self.info
            if image is not None:
                keyframe.image = image
            keyframe_pub.publish(keyframe)
            time.sleep(0.3)
        self.assertTrue(rosout.wait_for('loop_closure_node', 'keyframe 0 carries no image',
                                        'no loop search', level=Log.WARN),
                        rosout.dump('loop_closure_node'))
        self.assertTrue(rosout.wait_for('mapping_node', 'new tracker session', level=Log.WARN))

        # Loop constraints the mapping node must refuse.
        def constraint(scale, from_id, to_id, of_session):
            c = Sim3Constraint()
            c.session, c.from_keyframe_id, c.to_keyframe_id = of_session, from_id, to_id
            c.measurement.rotation.w, c.measurement.scale = 1.0, scale
            return c
        constraint_pub.publish(constraint(-1.0, 1, 0, session))
        self.assertTrue(rosout.wait_for('mapping_node', 'loop 1 -> 0 refused', 'non-positive',
                                        level=Log.WARN), rosout.dump('mapping_node'))
        constraint_pub.publish(constraint(1.0, 77, 78, session))
        self.assertTrue(rosout.wait_for('mapping_node', 'loop 77 -> 78 not applied',
                                        'no keyframe 77', level=Log.WARN))
        constraint_pub.publish(constraint(1.0, 1, 0, 999))
        self.assertTrue(rosout.wait_for('mapping_node', 'loop 1 -> 0 refused',
                                        'tracker session 999', level=Log.WARN))

        # Relocalisation requests: without an image (refused at once), then one the loop closer
        # cannot place (no keyframe with a usable image): both answered with the reason.
        request = RelocalisationRequest()
        request.session, request.frame_index = session, 7
        request_pub.publish(request)
        self.assertTrue(sds.wait_until(lambda: answers, 10))
        self.assertFalse(answers[0].success)
        self.assertIn('carries no image', answers[0].reason)
        self.assertTrue(rosout.wait_for('loop_closure_node', 'cannot relocalise frame 7',
                                        level=Log.ERROR))
        request.frame_index, request.image = 8, self.images[0]
        request_pub.publish(request)
        self.assertTrue(sds.wait_until(lambda: len(answers) >= 2, 10))
        self.assertEqual((answers[1].frame_index, answers[1].success), (8, False))
        self.assertIn('keyframe', answers[1].reason)
        self.assertTrue(rosout.wait_for('loop_closure_node', 'keyframe 1',
                                        'its image is unusable', level=Log.WARN))
        self.assertAlive('/tracking_node', '/mapping_node', '/loop_closure_node')
        print('what the mapping and loop closure nodes said about the bad messages:')
        for name, level, text in rosout.find('', level=Log.WARN):
            if name.endswith(('mapping_node', 'loop_closure_node')) and 'session' not in text:
                print('  %s [%s] %s' % (name, {Log.WARN: 'WARN', Log.ERROR: 'ERROR'}.get(level),
                                        text))

    def test_5_invalid_same_session_keyframes(self):
        """After test_4 the mapping node holds keyframes 0 and 1 of session 4242."""
        rosout = self.rosout
        keyframe_pub = rospy.Publisher('/keyframes', Keyframe, queue_size=10)
        assert sds.wait_until(lambda: keyframe_pub.get_num_connections() >= 2, 30)
        time.sleep(0.5)
        session = 4242

        def keyframe(kf_id, stamp):
            k = Keyframe()
            k.header.stamp = rospy.Time.from_sec(stamp)
            k.session, k.id = session, kf_id
            k.T_kf_world.orientation.w = 1.0
            k.T_kf_world.position.x = -0.1
            k.camera = copy.deepcopy(self.info)
            return k

        bad = []
        zero_k = keyframe(2, 2010.0)
        zero_k.camera.K = [0.0] * 9
        nan_k = keyframe(2, 2011.0)
        nan_k.camera.K = [float('nan')] + list(nan_k.camera.K[1:])
        far = keyframe(2, 2012.0)
        far.T_kf_world.position.z = 1e9
        crowded = keyframe(2, 2013.0)
        crowded.observations = [Observation(point_id=1, x=0.0, y=0.0)] * 50000
        ahead = keyframe(5002, 2014.0)
        for k in (zero_k, nan_k, far, crowded, ahead):
            keyframe_pub.publish(k)
            time.sleep(0.3)
        keyframe_pub.publish(keyframe(2, 2002.0))  # the real keyframe 2
        # One line per kind of refusal (throttled): the camera's, then the content's.
        self.assertTrue(rosout.wait_for('mapping_node', 'keyframe 2 refused', 'camera',
                                        level=Log.ERROR), rosout.dump('mapping_node'))
        self.assertTrue(rosout.wait_for('mapping_node', 'keyframe 2 has a pose 1e+09',
                                        level=Log.WARN), rosout.dump('mapping_node'))
        path = os.path.join(sds.work_dir(), 'bad_input_keyframes.txt')
        save = rospy.ServiceProxy('/mapping_node/save_trajectory', SaveTrajectory)

        def saved_stamps():
            response = save(path=path)
            self.assertTrue(response.success, response.message)
            with open(path) as f:
                rows = [line.split() for line in f if not line.startswith('#')]
            self.assertTrue(all(abs(float(v)) < 1e3 for row in rows for v in row[1:4]), rows)
            return [round(float(row[0]), 3) for row in rows]
        self.assertTrue(sds.wait_until(lambda: 2002.0 in saved_stamps(), 10))
        self.assertEqual(saved_stamps(), [2000.0, 2001.0, 2002.0])
        self.assertAlive('/tracking_node', '/mapping_node', '/loop_closure_node')


if __name__ == '__main__':
    rospy.init_node('test_bad_input')
    rostest.rosrun('scale_drift_slam', 'bad_input', BadInput)
