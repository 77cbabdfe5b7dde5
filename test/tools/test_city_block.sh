#!/usr/bin/env bash
# city_block end to end with run_sequence (issue 18; the turn fix of issue 16).
# Renders the forward-driving city_block (KITTI-like 1241x376 camera at 10 Hz, ~370 m round one
# block and on past the start, noise 1), runs the SLAM with the mapper and the loop closer inline
# (deterministic) and asserts what issue 18 asks of it: >= 95 % of the frames tracked, the loop
# closed at a true revisit with the scale drift the map really had (loop_checks.py), and the
# corrected trajectory within 0.5 % of the path (ATE after Sim(3) alignment).
# Before the flow started at the predicted positions (motion_prior.predict_flow) tracking was lost
# in the fourth turn with seed 1 (frames 390-438, 89.5 % tracked; doc/frontend.md). ~15 s.
# SDS_CITY_TRAFFIC=1 (test_city_block_traffic.sh): the same drive with --traffic.
set -euo pipefail
bin="${SDS_BIN_DIR:?}"
checks="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)/loop_checks.py"
traffic="${SDS_CITY_TRAFFIC:-0}"
work="${SDS_TEST_OUTPUT_DIR:?}/city_block$([[ $traffic == 1 ]] && echo _traffic || true)"
seed="${SDS_CITY_SEED:-1}"
rm -rf "$work"
mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }
printf "system:\n  mapping_thread: false\n" > "$work/inline.yaml"

scene=(--scene city_block)
[[ $traffic == 1 ]] && scene+=(--traffic)
"$bin/render_sequence" "${scene[@]}" --noise 1 --seed "$seed" --out "$work/seq" --quiet
if [[ $traffic == 1 ]]; then
  cars=$(sed -n 's/.*traffic: \([0-9]*\) moving cars.*/\1/p' "$work/seq/rgb.txt" | head -1)
  echo "traffic: ${cars:-0} moving cars"
  [[ "${cars:-0}" -ge 10 ]] || fail "expected at least 10 moving cars in the city_block traffic"
fi
"$bin/run_sequence" "$work/seq" --out "$work/out" --config "$work/inline.yaml" --quiet \
  > "$work/run.log" 2>&1 || { tail -20 "$work/run.log"; fail "run_sequence"; }
grep -E "^frames|^loops" "$work/run.log"

/usr/bin/python3 - "$work/out/summary.json" <<'PY' || fail "tracking or loop"
import json, sys
s = json.load(open(sys.argv[1]))
print("tracked %d of %d frames (%.1f %%), %d loop(s) closed"
      % (s["tracked"], s["frames"], 100.0 * s["tracked"] / s["frames"], len(s["loops"])))
assert s["tracked"] >= 0.95 * s["frames"], "fewer than 95 % of the frames tracked"
assert len(s["loops"]) >= 1, "the loop was not closed"
PY
# Keyframes come every ~3.7 m on this drive and place recognition need not pick the nearest pair:
# true loops have joined keyframes 2-8 m apart along the same street (seeds 1-3), their relative
# pose measured within 0.1 deg and 1 % of the distance. A look-alike street elsewhere fails the
# relative pose's direction and distance checks; the limit keeps the loop at the same place.
/usr/bin/python3 "$checks" loops "$work/out/summary.json" "$work/seq/groundtruth.txt" \
  --max-distance 10
/usr/bin/python3 "$checks" scale "$work/out/summary.json" "$work/seq/groundtruth.txt"
"$bin/evaluate_trajectory" "$work/seq/groundtruth.txt" "$work/out/trajectory.txt" --json \
  > "$work/evaluation.json"
/usr/bin/python3 - "$work/evaluation.json" <<'PY' || fail "ATE bound"
import json, sys
e = json.load(open(sys.argv[1]))
ratio = e["ate"]["rmse"] / e["ground_truth_path_length"]
print("ATE %.3f m = %.3f %% of the %.1f m path" % (e["ate"]["rmse"], 100 * ratio,
                                                  e["ground_truth_path_length"]))
assert ratio <= 0.005, ratio
PY
echo "PASS"
