#!/usr/bin/python3
"""Checks of loop closure runs against the rendered ground truth, shared by the tool tests.

  loop_checks.py loops SUMMARY GROUNDTRUTH [--max-distance M] [--keyframes K]
      every loop in run_sequence's summary.json is a true loop: it joins two keyframes whose true
      camera centres are within M metres (default 3) and whose optical axes are within 30
      degrees, and the relative pose it measured (S_current_loop) is the true one: its rotation
      within 3 degrees, and where the centres are over 1 m apart the direction from one to the
      other within 20 degrees and the distance within 25 % (the measured one in metres by the
      map's local scale over the K keyframes up to the current one, as in `scale`): a loop onto
      a look-alike place gets that geometry wrong.
  loop_checks.py scale SUMMARY GROUNDTRUTH [--keyframes K] [--tolerance F]
      the relative scale measured at each loop is within F (default 0.05) of the drift the map
      really had just before that loop's correction (run_sequence writes those keyframes beside
      the summary, keyframes_before_loop_N.txt; after a first correction the trajectory as
      tracked is no longer that map): the ratio of the map's local scales against the ground
      truth over the K keyframes (default 8) up to the current keyframe and from the loop one.
Prints one line per loop; exits 1 with the reason on the first failure.
"""
import json
import os
import sys

import numpy as np


def load_tum(path):
    rows = [l.split() for l in open(path) if l.strip() and not l.startswith("#")]
    return np.array([[float(v) for v in r[:8]] for r in rows])


def nearest(poses, stamp):
    return poses[np.argmin(np.abs(poses[:, 0] - stamp))]


def rotation(pose):
    """Rotation matrix of a TUM row's (or S_current_loop's) quaternion qx qy qz qw."""
    x, y, z, w = pose
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def optical_axis(pose):
    """Camera z in the world of a TUM row (camera to world)."""
    return rotation(pose[4:8])[:, 2]


def angle_deg(a, b):
    return np.degrees(np.arccos(np.clip(a @ b / np.linalg.norm(a) / np.linalg.norm(b), -1, 1)))


def relative_pose_errors(loop, a, b):
    """Rotation error (degrees) of the measured S_current_loop against the true T_current_loop,
    and the angle between the measured and the true loop-keyframe centre seen from the current
    keyframe (degrees). a, b: the true poses (TUM rows, camera to world) of the current and the
    loop keyframe."""
    S = loop["S_current_loop"]  # qx qy qz qw tx ty tz log-scale: x_current = S x_loop
    R_cw, R_lw = rotation(a[4:8]).T, rotation(b[4:8]).T
    R_true = R_cw @ R_lw.T
    cos = (np.trace(rotation(S[0:4]).T @ R_true) - 1) / 2
    rotation_error = np.degrees(np.arccos(np.clip(cos, -1, 1)))
    # The loop camera's centre in the current camera: measured S (0) = t, true R_cw (c_l - c_c).
    direction_error = angle_deg(np.array(S[4:7]), R_cw @ (b[1:4] - a[1:4]))
    return rotation_error, direction_error


def local_scale(estimate, truth):
    """Estimate units per metre over the poses `estimate`: the spread of the estimated centres
    about their mean divided by the spread of the true ones (Umeyama's scale for a rigid fit)."""
    rows = [(e[1:4], nearest(truth, e[0])[1:4]) for e in estimate]
    if len(rows) < 5:
        raise SystemExit("FAIL: only %d keyframes for a local scale" % len(rows))
    est = np.array([r[0] for r in rows])
    gt = np.array([r[1] for r in rows])
    return np.sqrt(((est - est.mean(0)) ** 2).sum() / ((gt - gt.mean(0)) ** 2).sum())


def keyframes_around(loop, folder, count):
    """The map just before the loop's correction (keyframes_before_loop_N.txt): its `count`
    keyframes up to the current keyframe and its `count` keyframes from the loop keyframe on."""
    before = load_tum(os.path.join(folder, loop["keyframes_before"]))
    before = before[np.argsort(before[:, 0])]
    up_to_current = before[before[:, 0] <= loop["current_stamp"] + 1e-6][-count:]
    from_loop = before[before[:, 0] >= loop["loop_stamp"] - 1e-6][:count]
    return up_to_current, from_loop


def option(name, default):
    return float(sys.argv[sys.argv.index(name) + 1]) if name in sys.argv else default


def main():
    mode, summary, truth = sys.argv[1], json.load(open(sys.argv[2])), load_tum(sys.argv[3])
    loops = summary["loops"]
    folder = os.path.dirname(os.path.abspath(sys.argv[2]))
    count = int(option("--keyframes", 8))
    if mode == "loops":
        limit = option("--max-distance", 3.0)
        for loop in loops:
            a, b = nearest(truth, loop["current_stamp"]), nearest(truth, loop["loop_stamp"])
            distance = np.linalg.norm(a[1:4] - b[1:4])
            angle = np.degrees(np.arccos(np.clip(optical_axis(a) @ optical_axis(b), -1, 1)))
            rotation_error, direction_error = relative_pose_errors(loop, a, b)
            # The measured centre-to-centre distance is in the current map's units; it is
            # checked only for loops over 1 m, so a loop closed within the map's first keyframes
            # (too few for a local scale) is checked on its rotation alone.
            measured = float("nan")
            if distance > 1:
                units_per_metre = local_scale(keyframes_around(loop, folder, count)[0], truth)
                measured = np.linalg.norm(loop["S_current_loop"][4:7]) / units_per_metre
            print("loop %d -> %d: true distance %.2f m, view angle %.1f deg; measured relative "
                  "pose: rotation error %.2f deg, direction error %.1f deg, distance %.2f m"
                  % (loop["current_keyframe"], loop["loop_keyframe"], distance, angle,
                     rotation_error, direction_error, measured))
            if distance > limit or angle > 30:
                raise SystemExit("FAIL: a false loop was accepted (too far apart)")
            if rotation_error > 3 or (distance > 1 and (direction_error > 20 or
                                                         abs(measured / distance - 1) > 0.25)):
                raise SystemExit("FAIL: the loop's relative pose is not the true one")
    elif mode == "scale":
        tolerance = option("--tolerance", 0.05)
        for loop in loops:
            up_to_current, from_loop = keyframes_around(loop, folder, count)
            drift = local_scale(up_to_current, truth) / local_scale(from_loop, truth)
            print("loop %d -> %d: measured scale %.4f, true drift %.4f (error %.2f %%)"
                  % (loop["current_keyframe"], loop["loop_keyframe"], loop["scale"], drift,
                     100 * abs(loop["scale"] / drift - 1)))
            if abs(loop["scale"] / drift - 1) > tolerance:
                raise SystemExit("FAIL: the loop scale is not the drift the map had")
    else:
        raise SystemExit("usage: loop_checks.py loops|scale ...")


if __name__ == "__main__":
    main()
