#!/usr/bin/env bash
# city_block with --traffic end to end (issue 18): the same drive as test_city_block.sh with
# moving cars in the streets (oncoming, crossing at the junctions, turning in ahead of the camera;
# doc/sequences.md). The tracker must reject them: >= 95 % of the frames tracked, the loop closed
# at a true revisit with the map's true scale drift (loop_checks.py), and the corrected trajectory
# within the bound without traffic, 0.5 % of the path (ATE after Sim(3) alignment). Also checks
# that the traffic is there: the rendered description counts the moving cars. ~30 s.
set -euo pipefail
bin="${SDS_BIN_DIR:?}"
checks="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)/loop_checks.py"
work="${SDS_TEST_OUTPUT_DIR:?}/city_block_traffic"
seed="${SDS_CITY_SEED:-1}"
rm -rf "$work"
mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }
printf "system:\n  mapping_thread: false\n" > "$work/inline.yaml"

"$bin/render_sequence" --scene city_block --traffic --noise 1 --seed "$seed" --out "$work/seq" \
  --quiet
cars=$(sed -n 's/.*traffic: \([0-9]*\) moving cars.*/\1/p' "$work/seq/rgb.txt" | head -1)
echo "traffic: ${cars:-0} moving cars"
[[ "${cars:-0}" -ge 10 ]] || fail "expected at least 10 moving cars in the city_block traffic"
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
/usr/bin/python3 "$checks" loops "$work/out/summary.json" "$work/seq/groundtruth.txt"
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
