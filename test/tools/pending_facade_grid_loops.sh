#!/usr/bin/env bash
# PENDING (not run by ctest: the name does not match test_*.sh): the whole system on the
# repetitive facade_grid scene (identical building bays and paving tiles, told apart only by the
# street furniture) must track it, keep the ATE <= 1 % of the path and accept no false loop.
# Fails today: at keyframe 33 (t = 15.6 s) place recognition and the geometric check accept a loop
# to keyframe 1 whose camera is 21.7 m away (the facade and paving look the same there: 273
# inliers, 0.60 px RMSE), and the correction ruins the map (ATE ~6 % of the path). Rename to
# test_facade_grid_loops.sh once the loop closer refuses it. ~7 s.
set -euo pipefail
bin="${SDS_BIN_DIR:?}"
work="${SDS_TEST_OUTPUT_DIR:?}/facade_grid_loops"
dir="$(dirname "${BASH_SOURCE[0]}")"
rm -rf "$work"
mkdir -p "$work"

"$bin/render_sequence" --scene facade_grid --out "$work/grid" --quiet > "$work/render.log"
"$bin/run_sequence" "$work/grid" --out "$work/run" --quiet > "$work/run.log" 2>&1 ||
  { cat "$work/run.log"; echo "FAIL: run_sequence" >&2; exit 1; }
"$bin/evaluate_trajectory" "$work/grid/groundtruth.txt" "$work/run/trajectory.txt" --json \
  > "$work/evaluation.json"
/usr/bin/python3 "$dir/loop_checks.py" loops "$work/run/summary.json" "$work/grid/groundtruth.txt"
/usr/bin/python3 "$dir/effects_checks.py" facade_grid "$work/run/frames.csv" "$work/evaluation.json"
echo "facade_grid loop closure test passed"
