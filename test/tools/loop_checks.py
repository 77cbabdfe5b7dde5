#!/usr/bin/python3
"""Checks of loop closure runs against the rendered ground truth, shared by the tool tests.

  loop_checks.py loops SUMMARY GROUNDTRUTH [--max-distance M]
      every loop in run_sequence's summary.json joins two keyframes whose true camera centres are
      within M metres (default 3) and whose optical axes are within 30 degrees: a true loop.
  loop_checks.py scale SUMMARY GROUNDTRUTH LIVE_TRAJECTORY [--window S] [--tolerance F]
      the relative scale measured at each loop is within F (default 0.05) of the drift the live
      (uncorrected) trajectory really had: the ratio of its local scales against the ground truth
      over S seconds (default 2) at the current and at the loop keyframe.
Prints one line per loop; exits 1 with the reason on the first failure.
"""
import json
import sys

import numpy as np


def load_tum(path):
    rows = [l.split() for l in open(path) if l.strip() and not l.startswith("#")]
    return np.array([[float(v) for v in r[:8]] for r in rows])


def nearest(poses, stamp):
    return poses[np.argmin(np.abs(poses[:, 0] - stamp))]


def optical_axis(pose):
    x, y, z, w = pose[4:8]
    # third column of the rotation matrix of the quaternion (camera z in the world)
    return np.array([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])


def local_scale(estimate, truth, start, end):
    """Estimate units per metre over [start, end]: the spread of the estimated centres about
    their mean divided by the spread of the true ones (Umeyama's scale for a rigid fit)."""
    rows = [(e[1:4], nearest(truth, e[0])[1:4]) for e in estimate if start <= e[0] <= end]
    if len(rows) < 5:
        raise SystemExit("FAIL: only %d frames in [%.2f, %.2f]" % (len(rows), start, end))
    est = np.array([r[0] for r in rows])
    gt = np.array([r[1] for r in rows])
    return np.sqrt(((est - est.mean(0)) ** 2).sum() / ((gt - gt.mean(0)) ** 2).sum())


def option(name, default):
    return float(sys.argv[sys.argv.index(name) + 1]) if name in sys.argv else default


def main():
    mode, summary, truth = sys.argv[1], json.load(open(sys.argv[2])), load_tum(sys.argv[3])
    loops = summary["loops"]
    if mode == "loops":
        limit = option("--max-distance", 3.0)
        for loop in loops:
            a, b = nearest(truth, loop["current_stamp"]), nearest(truth, loop["loop_stamp"])
            distance = np.linalg.norm(a[1:4] - b[1:4])
            angle = np.degrees(np.arccos(np.clip(optical_axis(a) @ optical_axis(b), -1, 1)))
            print("loop %d -> %d: true distance %.2f m, view angle %.1f deg"
                  % (loop["current_keyframe"], loop["loop_keyframe"], distance, angle))
            if distance > limit or angle > 30:
                raise SystemExit("FAIL: a false loop was accepted")
    elif mode == "scale":
        live = load_tum(sys.argv[4])
        window, tolerance = option("--window", 2.0), option("--tolerance", 0.05)
        for loop in loops:
            at_current = local_scale(live, truth, loop["current_stamp"] - window,
                                     loop["current_stamp"])
            at_loop = local_scale(live, truth, loop["loop_stamp"], loop["loop_stamp"] + window)
            drift = at_current / at_loop
            print("loop %d -> %d: measured scale %.4f, true drift %.4f (error %.2f %%)"
                  % (loop["current_keyframe"], loop["loop_keyframe"], loop["scale"], drift,
                     100 * abs(loop["scale"] / drift - 1)))
            if abs(loop["scale"] / drift - 1) > tolerance:
                raise SystemExit("FAIL: the loop scale is not the drift the map had")
    else:
        raise SystemExit("usage: loop_checks.py loops|scale ...")


if __name__ == "__main__":
    main()
