#!/usr/bin/python3
"""play_sequence: plays a rendered sequence to the SLAM nodes, for demo.launch and scripts/demo.

Renders the scene with render_sequence when its bag is not there yet (cached), waits until the
tracking and mapping nodes are up, plays the bag with the clock (rosbag play --clock), logs the
loops the loop closure node found, records the camera trajectory (corrected: the tracking node's
last Path, whose history moves with each loop correction; as tracked: tf map -> optical frame at
every image stamp, as it was published), then asks the mapping node to save its keyframes and
exits. Private parameters:
  ~scene (courtyard_loop), ~frames (0: all), ~bag (where the bag is or goes), ~rate (1.0),
  ~map_frame (map), ~optical_frame (camera_optical_frame),
  ~trajectory (TUM file of every tracked frame, corrected by the loop closures; '' = none),
  ~tf_trajectory (TUM file of every tracked frame as tracked, from tf; '' = none),
  ~keyframe_trajectory (TUM file written by /mapping_node/save_trajectory; '' = none).
"""

import os
import subprocess
import sys
import threading
import time

import roslib.packages
import rospy
import tf2_ros
from nav_msgs.msg import Path
from scale_drift_slam.msg import Keyframe, MapUpdate, Sim3Constraint, TrackingStatus
from scale_drift_slam.srv import SaveTrajectory


def render(scene, frames, bag):
    folder = os.path.splitext(bag)[0]
    if os.path.exists(bag) and os.path.isdir(folder):
        rospy.loginfo('using the rendered %s in %s', scene, bag)
        return folder
    renderer = roslib.packages.find_node('scale_drift_slam', 'render_sequence')[0]
    os.makedirs(os.path.dirname(os.path.abspath(bag)), exist_ok=True)
    rospy.loginfo('rendering %s into %s (once; ~10 s)', scene, bag)
    command = [renderer, '--scene', scene, '--noise', '1', '--out', folder, '--bag', bag + '.tmp',
               '--quiet']
    if frames > 0:
        command += ['--frames', str(frames)]
    subprocess.check_call(command)
    os.rename(bag + '.tmp', bag)
    return folder


def body_to_optical(q):
    """The optical frame's rotation from the camera body's (REP 103), quaternions x y z w."""
    ax, ay, az, aw = q
    bx, by, bz, bw = -0.5, 0.5, -0.5, 0.5
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def write_tum(path, poses, comment):
    with open(path, 'w') as f:
        f.write('# %s\n# timestamp tx ty tz qx qy qz qw\n' % comment)
        for pose in poses:
            f.write('%.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n' % pose)


def main():
    rospy.init_node('play_sequence')
    scene = rospy.get_param('~scene', 'courtyard_loop')
    frames = int(rospy.get_param('~frames', 0))
    bag = rospy.get_param('~bag', os.path.join(os.environ.get('ROS_HOME', '.'), scene + '.bag'))
    rate = float(rospy.get_param('~rate', 1.0))
    map_frame = rospy.get_param('~map_frame', 'map')
    optical_frame = rospy.get_param('~optical_frame', 'camera_optical_frame')
    trajectory = rospy.get_param('~trajectory', '')
    tf_trajectory = rospy.get_param('~tf_trajectory', '')
    keyframe_trajectory = rospy.get_param('~keyframe_trajectory', '')

    folder = render(scene, frames, bag)
    buffer = tf2_ros.Buffer(cache_time=rospy.Duration(24 * 3600))
    tf2_ros.TransformListener(buffer)
    lock = threading.Lock()
    tracked, keyframes, updates, loops, paths = [], [], [], [], []

    def on_status(msg):
        if msg.has_pose:
            with lock:
                tracked.append(msg.header.stamp)
    rospy.Subscriber('/tracking_status', TrackingStatus, on_status, queue_size=1000)
    rospy.Subscriber('/keyframes', Keyframe, lambda m: keyframes.append(m.header.stamp),
                     queue_size=100)
    rospy.Subscriber('/map_updates', MapUpdate, lambda m: updates.append(m.header.stamp),
                     queue_size=100)
    rospy.Subscriber('/loop_constraints', Sim3Constraint, loops.append, queue_size=10)
    rospy.Subscriber('/path', Path, paths.append, queue_size=10)
    for service in ('/tracking_node/reset', '/mapping_node/save_trajectory'):
        rospy.wait_for_service(service, timeout=60)
    time.sleep(1.0)

    rospy.loginfo('playing %s at rate %.2f', bag, rate)
    start = time.time()
    # The bag's ground truth on /tf (world -> camera_ground_truth) is a tree of its own: keep it
    # off /tf, where rviz would report it as unconnected to map.
    player = subprocess.Popen(['rosbag', 'play', '--clock', '--quiet', '-d', '1', '-r', str(rate),
                               bag, '/tf:=/ground_truth/tf'], stdin=subprocess.DEVNULL,
                              stdout=subprocess.DEVNULL)
    player.wait()
    # Let tracking take the last frames and mapping answer the last keyframe.
    deadline = time.time() + 30
    while time.time() < deadline and not (keyframes and updates and updates[-1] >= keyframes[-1]):
        time.sleep(0.2)
    time.sleep(1.0)
    rospy.loginfo('played in %.1f s: %d frames tracked, %d keyframes, %d loops closed',
                  time.time() - start, len(tracked), len(keyframes), len(loops))
    for c in loops:
        rospy.loginfo('loop: keyframe %d -> keyframe %d, scale %.4f, %d inliers',
                      c.from_keyframe_id, c.to_keyframe_id, c.measurement.scale, c.inliers)

    with lock:
        stamps = list(tracked)
    from_tf = {}
    for stamp in stamps:  # the history as it was published
        try:
            t = buffer.lookup_transform(map_frame, optical_frame, stamp).transform
        except tf2_ros.TransformException as e:
            rospy.logwarn('no tf at %.6f: %s', stamp.to_sec(), e)
            continue
        from_tf[stamp.to_sec()] = (stamp.to_sec(), t.translation.x, t.translation.y,
                                   t.translation.z, t.rotation.x, t.rotation.y, t.rotation.z,
                                   t.rotation.w)
    if tf_trajectory:
        write_tum(tf_trajectory, sorted(from_tf.values()), 'every tracked frame as tracked, '
                  'from tf: %s -> %s' % (map_frame, optical_frame))
        rospy.loginfo('wrote %d poses from tf to %s', len(from_tf), tf_trajectory)
    if trajectory:
        # The last Path (the corrected history; published every few frames and at each loop
        # correction), then tf for the frames after it (tracked after the last correction).
        poses = []
        for p in (paths[-1].poses if paths else []):
            t, q = p.pose.position, p.pose.orientation
            poses.append((p.header.stamp.to_sec(), t.x, t.y, t.z) +
                         body_to_optical((q.x, q.y, q.z, q.w)))
        last = poses[-1][0] if poses else 0.0
        poses += sorted(pose for stamp, pose in from_tf.items() if stamp > last + 1e-6)
        write_tum(trajectory, poses, 'every tracked frame, corrected by the loop closures: the '
                  'path in %s, camera optical frame' % map_frame)
        rospy.loginfo('wrote %d corrected poses to %s', len(poses), trajectory)
    if keyframe_trajectory:
        answer = rospy.ServiceProxy('/mapping_node/save_trajectory', SaveTrajectory)(
            keyframe_trajectory)
        (rospy.loginfo if answer.success else rospy.logerr)('mapping_node: %s', answer.message)
    rospy.loginfo('ground truth: %s', os.path.join(folder, 'groundtruth.txt'))
    return 0


if __name__ == '__main__':
    sys.exit(main())
