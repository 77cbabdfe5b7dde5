#!/usr/bin/python3
"""Checks of one run_sequence run against its rendered ground truth, for the camera-effect tests.

  effects_checks.py NAME FRAMES_CSV EVALUATION_JSON [--first-within N]
      the first pose within N frames (default 30), >= 95 % of the frames from it on tracked, and
      the ATE after Sim(3) alignment <= 1 % of the path. Prints one line; exits 1 with the reason.
"""
import csv
import json
import sys


def main():
    name, frames = sys.argv[1], list(csv.DictReader(open(sys.argv[2])))
    evaluation = json.load(open(sys.argv[3]))
    within = int(sys.argv[sys.argv.index("--first-within") + 1]) if "--first-within" in sys.argv else 30
    posed = [int(f["frame"]) for f in frames if f["state"] in ("good", "weak")]
    if not posed:
        raise SystemExit("FAIL %s: never initialised; last message: %s" % (name, frames[-1]["message"]))
    first = posed[0]
    after = frames[first:]
    tracked = sum(f["state"] in ("good", "weak") for f in after)
    ratio = evaluation["ate"]["rmse"] / evaluation["ground_truth_path_length"]
    print("%-16s first pose at frame %d, tracked %d of %d (%.1f %%), ATE %.4f m = %.3f %% of %.2f m"
          % (name, first, tracked, len(after), 100.0 * tracked / len(after),
             evaluation["ate"]["rmse"], 100 * ratio, evaluation["ground_truth_path_length"]))
    if first > within:
        raise SystemExit("FAIL %s: first pose at frame %d (> %d)" % (name, first, within))
    if tracked < 0.95 * len(after):
        lost = [f for f in after if f["state"] not in ("good", "weak")]
        raise SystemExit("FAIL %s: only %d of %d tracked; first untracked frame %s: %s"
                         % (name, tracked, len(after), lost[0]["frame"], lost[0]["message"]))
    if ratio > 0.01:
        raise SystemExit("FAIL %s: ATE %.3f %% of the path (> 1 %%)" % (name, 100 * ratio))


if __name__ == "__main__":
    main()
