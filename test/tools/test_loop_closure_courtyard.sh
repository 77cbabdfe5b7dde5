#!/usr/bin/env bash
# Loop closure end to end with run_sequence on the rendered courtyard_loop (640x480, the mapper and
# the loop closer inline so that the run is deterministic): the loop is detected and closed once,
# it joins two keyframes that really see the same place, the relative scale it measures is the
# drift the map really had (within 5 %), and the corrected trajectory is within 0.5 % of the path
# (ATE after Sim(3) alignment). With the camera covered for 30 frames in the middle, the tracker
# says it is lost, relocalises within 15 frames of the image coming back, and the bound holds.
# ~1 min.
set -euo pipefail
bin="${SDS_BIN_DIR:?}"
checks="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)/loop_checks.py"
work="${SDS_TEST_OUTPUT_DIR:?}/loop_closure_courtyard"
rm -rf "$work"
mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }
printf "system:\n  mapping_thread: false\n" > "$work/inline.yaml"

run() {  # name [render flags]: renders courtyard_loop, runs the SLAM, checks the common bounds
  local name="$1"
  shift
  "$bin/render_sequence" --scene courtyard_loop --noise 1 --seed 1 --out "$work/$name" --quiet "$@"
  "$bin/run_sequence" "$work/$name" --out "$work/$name.out" --config "$work/inline.yaml" --quiet \
    > "$work/$name.log" 2>&1 || { cat "$work/$name.log"; fail "run_sequence on $name"; }
  grep -E "loop|relocalis" "$work/$name.log" | grep -v "^query" || true
  /usr/bin/python3 - "$work/$name.out/summary.json" <<'PY' || fail "$name: not one loop"
import json, sys
loops = json.load(open(sys.argv[1]))["loops"]
assert len(loops) == 1, "%d loops closed, expected one" % len(loops)
PY
  /usr/bin/python3 "$checks" loops "$work/$name.out/summary.json" "$work/$name/groundtruth.txt"
  /usr/bin/python3 "$checks" scale "$work/$name.out/summary.json" "$work/$name/groundtruth.txt" \
    "$work/$name.out/trajectory_as_tracked.txt"
  "$bin/evaluate_trajectory" "$work/$name/groundtruth.txt" "$work/$name.out/trajectory.txt" \
    --json > "$work/$name.evaluation.json"
  /usr/bin/python3 - "$work/$name.evaluation.json" "$name" <<'PY' || fail "$name: ATE bound"
import json, sys
e = json.load(open(sys.argv[1]))
ratio = e["ate"]["rmse"] / e["ground_truth_path_length"]
print("%s: ATE %.4f m = %.3f%% of the %.1f m path" % (sys.argv[2], e["ate"]["rmse"], 100 * ratio,
                                                      e["ground_truth_path_length"]))
assert ratio < 0.005, ratio
PY
}

run courtyard
grep -q "^loop .* corrected: sim3 graph.*total" "$work/courtyard.log" || fail "no correction times printed"

# The camera covered from 15 s for 1 s (frames 450-479 black).
run blackout --blackout 15:1
grep -q "lost after" "$work/blackout.log" || fail "the tracker did not say it was lost"
/usr/bin/python3 - "$work/blackout.out/trajectory_as_tracked.txt" <<'PY' || fail "relocalisation"
import sys
stamps = [float(l.split()[0]) for l in open(sys.argv[1]) if l.strip() and not l.startswith("#")]
back = 1000.0 + 16.0  # the first frame after the blackout (render_sequence starts at 1000 s)
resumed = min(t for t in stamps if t >= back - 1e-6)
frames = round((resumed - back) * 30.0)
print("tracking resumed %d frames after the image came back" % frames)
assert frames <= 15, frames
PY
echo "PASS"
