"""Shared helpers of the scale_drift_slam rostests: rendering test bags (cached), playing them,
collecting rosout, recording the camera trajectory from tf and scoring it with the package's own
evaluate_trajectory tool."""

import math
import os
import signal
import subprocess
import threading
import time
import json
import xmlrpc.client

import rosgraph
import roslib.packages
import rospkg
import rospy
from rosgraph_msgs.msg import Log

PKG = 'scale_drift_slam'


def tool(name):
    """Path of one of the package's executables (render_sequence, evaluate_trajectory, ...)."""
    found = roslib.packages.find_node(PKG, name)
    if not found:
        raise RuntimeError('%s not found: build the package first' % name)
    return found[0]


def work_dir():
    path = os.path.join(rospkg.get_ros_home(), 'scale_drift_slam_rostest')
    os.makedirs(path, exist_ok=True)
    return path


def render_bag(scene, frames, extra=()):
    """Renders `scene` (first `frames` frames, 1 grey level of noise) as a bag and a TUM folder
    in the work folder, unless a copy newer than render_sequence is there. Returns (bag, folder).
    Tests running at once take turns through a lock file."""
    import fcntl
    name = '%s_%d%s' % (scene, frames, ''.join(x.replace('-', '_') for x in extra))
    bag = os.path.join(work_dir(), name + '.bag')
    folder = os.path.join(work_dir(), name)
    renderer = tool('render_sequence')
    with open(os.path.join(work_dir(), name + '.lock'), 'w') as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        fresh = (os.path.exists(bag) and os.path.isdir(folder) and
                 os.path.getmtime(bag) > os.path.getmtime(renderer))
        if not fresh:
            subprocess.call(['rm', '-rf', folder, bag])
            subprocess.check_call([renderer, '--scene', scene, '--frames', str(frames),
                                   '--noise', '1', '--out', folder, '--bag', bag + '.tmp',
                                   '--quiet'] + list(extra))
            os.rename(bag + '.tmp', bag)
    return bag, folder


def play_bag(bag, rate=1.0, delay=1.0, wait=True, duration=None):
    """rosbag play with the clock (the first `duration` seconds of the bag when given); returns
    the process (finished when wait)."""
    limit = ['-u', str(duration)] if duration else []
    process = subprocess.Popen(['rosbag', 'play', '--clock', '--quiet', '-d', str(delay),
                                '-r', str(rate)] + limit + [bag], stdin=subprocess.DEVNULL,
                               stdout=subprocess.DEVNULL)
    if wait:
        process.wait()
    return process


class Rosout(object):
    """Collects every rosout message: (node name, level, text)."""

    def __init__(self):
        self.lock = threading.Lock()
        self.messages = []
        self.sub = rospy.Subscriber('/rosout', Log, self._callback, queue_size=1000)

    def _callback(self, msg):
        with self.lock:
            self.messages.append((msg.name, msg.level, msg.msg))

    def find(self, node, *words, level=None):
        """Messages of `node` that contain every word (case-insensitive), at `level` or above."""
        with self.lock:
            return [m for m in self.messages if m[0].endswith(node) and
                    (level is None or m[1] >= level) and
                    all(w.lower() in m[2].lower() for w in words)]

    def wait_for(self, node, *words, level=None, timeout=20.0):
        deadline = time.time() + timeout
        while time.time() < deadline:
            found = self.find(node, *words, level=level)
            if found:
                return found
            time.sleep(0.1)
        return []

    def dump(self, node, last=None, level=None):
        """`node`'s messages (its `last` ones when given; at `level` or above when given), one a
        line: a failure shows the end of a long log (CI folds the middle of what it prints)."""
        with self.lock:
            lines = ['%s [%d] %s' % m for m in self.messages if m[0].endswith(node) and
                     (level is None or m[1] >= level)]
        return '\n'.join(lines[-last:] if last else lines)


class _TimeoutTransport(xmlrpc.client.Transport):
    def make_connection(self, host):
        connection = super().make_connection(host)
        connection.timeout = 3.0
        return connection


def node_pid(name):
    """The process id of a running node (None when it is not registered or does not answer)."""
    master = rosgraph.Master('/sds_rostest')
    try:
        uri = master.lookupNode(name)
        proxy = xmlrpc.client.ServerProxy(uri, transport=_TimeoutTransport())
        code, _, pid = proxy.getPid('/sds_rostest')
        return pid if code == 1 else None
    except Exception:  # not registered, or the registration of a dead process
        return None


def kill_node(name):
    pid = node_pid(name)
    if pid is None:
        raise RuntimeError('node %s is not running' % name)
    os.kill(pid, signal.SIGKILL)
    return pid


def last_stamp(folder):
    """The stamp of a rendered sequence's last frame (its ground truth's last line)."""
    lines = [l for l in open(os.path.join(folder, 'groundtruth.txt')) if l.strip() and l[0] != '#']
    return float(lines[-1].split()[0])


def missing_frames(statuses, folder, max_leading=3):
    """Why the TrackingStatus messages do not cover every image of the rendered sequence, or ''.
    Only the first `max_leading` images may be missing: the node drops images until it has a
    calibration, and roscpp delivers the first CameraInfo and the first images of a bag in no
    fixed order (on a loaded machine several images may come first). Nothing may be missing
    after the first status, and nothing may be there twice."""
    lines = [l for l in open(os.path.join(folder, 'groundtruth.txt')) if l.strip() and l[0] != '#']
    stamps = [round(float(l.split()[0]), 6) for l in lines]
    seen = [round(s.header.stamp.to_sec(), 6) for s in statuses]
    if not seen or seen[0] not in stamps:
        return 'no status of a frame of the sequence'
    first = stamps.index(seen[0])
    if first > max_leading:
        return 'the first %d images have no status (at most %d may precede CameraInfo)' % (
            first, max_leading)
    if seen != stamps[first:]:
        return '%d statuses for the %d images from the first status on' % (
            len(seen), len(stamps) - first)
    return ''


def wait_for_last_frame(statuses, folder, timeout=30):
    """Waits until a TrackingStatus of the sequence's last frame arrived (missing_frames says
    whether every frame before it got one)."""
    end = last_stamp(folder)
    return wait_until(lambda: statuses and abs(statuses[-1].header.stamp.to_sec() - end) < 1e-3,
                      timeout)


def map_odom_recorder(store):
    """A /tf callback that appends (stamp, transform) of every map -> odom transform to store."""
    def record(msg):
        for t in msg.transforms:
            if t.header.frame_id == 'map' and t.child_frame_id == 'odom':
                store.append((t.header.stamp.to_sec(), t.transform))
    return record


def wait_until(condition, timeout, step=0.1):
    deadline = time.time() + timeout
    while time.time() < deadline:
        if condition():
            return True
        time.sleep(step)
    return condition()


def write_tum(path, poses):
    """poses: [(stamp, (tx, ty, tz), (qx, qy, qz, qw))]"""
    with open(path, 'w') as f:
        f.write('# timestamp tx ty tz qx qy qz qw\n')
        for stamp, t, q in poses:
            f.write('%.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n' % ((stamp,) + tuple(t) + tuple(q)))


def quaternion_product(a, b):
    """a * b for quaternions given as (x, y, z, w)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def rotation_angle_deg(a, b):
    """The angle of the rotation between two unit quaternions (x, y, z, w), in degrees."""
    dot = abs(sum(x * y for x, y in zip(a, b)))
    return math.degrees(2.0 * math.acos(min(1.0, dot)))


# The rotation of the camera optical frame in the camera body frame (REP 103): x y z w.
Q_BODY_OPTICAL = (-0.5, 0.5, -0.5, 0.5)


def path_poses(path):
    """A nav_msgs/Path of camera body poses as optical-frame poses [(stamp, t, q)]."""
    poses = []
    for p in path.poses:
        t, q = p.pose.position, p.pose.orientation
        poses.append((p.header.stamp.to_sec(), (t.x, t.y, t.z),
                      quaternion_product((q.x, q.y, q.z, q.w), Q_BODY_OPTICAL)))
    return poses


def ate_ratio(groundtruth, poses, name):
    """Writes poses [(stamp, t, q)] as work_dir()/name and returns (ATE / path length, report)."""
    estimate = os.path.join(work_dir(), name)
    write_tum(estimate, poses)
    report = evaluate(groundtruth, estimate)
    return report['ate']['rmse'] / report['ground_truth_path_length'], report


def evaluate(groundtruth, estimate):
    """evaluate_trajectory --json (ATE after Sim(3) alignment): the parsed report."""
    out = subprocess.check_output([tool('evaluate_trajectory'), groundtruth, estimate, '--json'])
    return json.loads(out.decode())


def read_images(bag, topic='/camera/image_raw', count=None, skip=0):
    """`count` sensor_msgs/Image of a bag after the first `skip`, and its first CameraInfo."""
    import rosbag
    images, info, seen = [], None, 0
    with rosbag.Bag(bag) as b:
        for t, msg, _ in b.read_messages(topics=[topic, '/camera/camera_info']):
            if t == topic:
                seen += 1
                if seen <= skip:
                    continue
                images.append(msg)
                if count is not None and len(images) >= count:
                    break
            elif info is None:
                info = msg
    return images, info


def png(grey, width, height):
    """A grey 8-bit image (bytes, row-major) as PNG bytes (no OpenCV in Debian's python3)."""
    import struct
    import zlib

    def chunk(tag, data):
        return (struct.pack('>I', len(data)) + tag + data +
                struct.pack('>I', zlib.crc32(tag + data) & 0xffffffff))
    raw = b''.join(b'\x00' + grey[y * width:(y + 1) * width] for y in range(height))
    return (b'\x89PNG\r\n\x1a\n' +
            chunk(b'IHDR', struct.pack('>IIBBBBB', width, height, 8, 0, 0, 0, 0)) +
            chunk(b'IDAT', zlib.compress(raw, 1)) + chunk(b'IEND', b''))


def reencode(msg, encoding):
    """A copy of a mono8 image message in another encoding (mono8, bgr8, rgb8, bgra8, mono16)."""
    import copy
    import numpy as np
    grey = np.frombuffer(msg.data, np.uint8).reshape(msg.height, msg.width)
    if encoding in ('bgr8', 'rgb8'):
        pixels = np.repeat(grey[:, :, None], 3, axis=2)
    elif encoding == 'bgra8':
        pixels = np.concatenate([np.repeat(grey[:, :, None], 3, axis=2),
                                 np.full(grey.shape + (1,), 255, np.uint8)], axis=2)
    elif encoding == 'mono16':
        pixels = (grey.astype('<u2') * 256).astype('<u2')
    else:
        pixels = grey
    out = copy.deepcopy(msg)
    out.encoding = encoding
    out.is_bigendian = 0
    out.step = msg.width * pixels.itemsize * (pixels.shape[2] if pixels.ndim == 3 else 1)
    out.data = pixels.tobytes()
    return out
