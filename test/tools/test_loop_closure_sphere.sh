#!/usr/bin/env bash
# Several loops in one run: run_sequence on the rendered sphere_flyover (a downward camera whose
# orbits over a textured sphere cross each other). Several loops are closed, each between
# keyframes that truly overlap (within 4 m: the camera flies 4 m above the surface and sees a
# 6.7 m x 5 m patch) with a measured scale within 5 % of the true drift, and the corrected
# trajectory's error is at most a third of the error of the same run without loop closure. ~1.5 min.
set -euo pipefail
bin="${SDS_BIN_DIR:?}"
checks="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)/loop_checks.py"
work="${SDS_TEST_OUTPUT_DIR:?}/loop_closure_sphere"
rm -rf "$work"
mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }
printf "system:\n  mapping_thread: false\n" > "$work/inline.yaml"

"$bin/render_sequence" --scene sphere_flyover --noise 1 --seed 1 --out "$work/sphere" --quiet
for variant in loops no_loops; do
  flag=""
  [[ "$variant" == no_loops ]] && flag="--no-loop-closure"
  "$bin/run_sequence" "$work/sphere" --out "$work/$variant" --config "$work/inline.yaml" --quiet \
    $flag > "$work/$variant.log" 2>&1 || { cat "$work/$variant.log"; fail "run_sequence $variant"; }
  "$bin/evaluate_trajectory" "$work/sphere/groundtruth.txt" "$work/$variant/trajectory.txt" \
    --json > "$work/$variant.evaluation.json"
done
grep -E "^loop .* corrected" "$work/loops.log" || true
/usr/bin/python3 "$checks" loops "$work/loops/summary.json" "$work/sphere/groundtruth.txt" \
  --max-distance 4
/usr/bin/python3 "$checks" scale "$work/loops/summary.json" "$work/sphere/groundtruth.txt"
/usr/bin/python3 - "$work" <<'PY' || fail "sphere_flyover bounds"
import json, sys
work = sys.argv[1]
loops = json.load(open(work + "/loops/summary.json"))["loops"]
with_loops = json.load(open(work + "/loops.evaluation.json"))["ate"]["rmse"]
without = json.load(open(work + "/no_loops.evaluation.json"))["ate"]["rmse"]
print("%d loops; ATE %.4f m with loop closure, %.4f m without" % (len(loops), with_loops, without))
assert len(loops) >= 3, len(loops)
assert with_loops <= without / 3.0, (with_loops, without)
PY
echo "PASS"
