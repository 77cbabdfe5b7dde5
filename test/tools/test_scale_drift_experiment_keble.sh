#!/usr/bin/env bash
# scale_drift_experiment keble on the paper's Keble College map: the outputs exist and the
# summary shows the paper's outcome (Figure 2). Tolerances, with the values measured here:
#  - before: path along the loop 11.46, loop gap 1.99;
#  - SE(3): the loop closes (gap < 0.1; the authors' 2 capped iterations leave 0.06, converged
#    0.001) but the scale stays wrong: path 11.4 +- 0.3 (as before);
#  - Sim(3): closed (gap < 0.01), the path stretches to "about 17": 16..19.5 (converged 18.25;
#    17.1 after 5 LM iterations; the valley is flat, see doc/pose_graph.md), at least 1.4 times
#    the path before; the last keyframe's scale is the measured 0.37 (+-0.02);
#  - structure-only BA lowers the reprojection error (median and 90th percentile), and the
#    Sim(3) map is more consistent than the SE(3) one (smaller errors after BA).
set -euo pipefail
bin="${SDS_BIN_DIR:?}/scale_drift_experiment"
map="${SDS_TEST_DATA_DIR:?}/keble_college/keble_college.txt"
out="${SDS_TEST_OUTPUT_DIR:?}/scale_drift_experiment_keble"
rm -rf "$out"

"$bin" --help | grep -q "keble --map FILE --out DIR"
"$bin" keble --map "$map" --out "$out"
for f in summary.json before.tum se3.tum sim3.tum se3_points.txt sim3_points.txt keble_top_view.png; do
  [[ -s "$out/$f" ]] || { echo "missing output $f" >&2; exit 1; }
done
[[ "$(grep -vc '^#' "$out/sim3.tum")" == 765 ]] || { echo "sim3.tum needs 765 keyframes" >&2; exit 1; }
[[ "$(grep -vc '^#' "$out/sim3_points.txt")" == 11885 ]] || { echo "need 11885 points" >&2; exit 1; }

/usr/bin/python3 - "$out/summary.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
failures = []
def check(name, ok, value):
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {value}")
    if not ok:
        failures.append(name)
b, se3, sim3 = s["before"], s["se3"], s["sim3"]
check("graph has 740 vertices, 739 consecutive + 1 loop edge",
      s["graph"]["vertices"] == 740 and s["graph"]["consecutive_edges"] == 739
      and s["graph"]["loop_edges"] == 1, s["graph"])
check("before: path 11.46", abs(b["path_length"] - 11.46) < 0.05, b["path_length"])
check("before: loop open (gap > 1.5)", b["loop_gap"] > 1.5, b["loop_gap"])
check("se3: loop closed (gap < 0.1)", se3["loop_gap"] < 0.1, se3["loop_gap"])
check("se3: scale still wrong (path 11.4 +- 0.3)", abs(se3["path_length"] - 11.4) < 0.3,
      se3["path_length"])
check("sim3: loop closed (gap < 0.01)", sim3["loop_gap"] < 0.01, sim3["loop_gap"])
check("sim3: path about 17 (16 .. 19.5)", 16.0 < sim3["path_length"] < 19.5, sim3["path_length"])
check("sim3: path stretched (>= 1.4 x before)", sim3["path_length"] > 1.4 * b["path_length"],
      sim3["path_length"] / b["path_length"])
check("sim3: last keyframe scale 0.37", abs(sim3["last_keyframe_scale"] - 0.3707) < 0.02,
      sim3["last_keyframe_scale"])
check("se3: scale stays 1", se3["last_keyframe_scale"] == 1.0, se3["last_keyframe_scale"])
for name, v in (("se3", se3), ("sim3", sim3)):
    g = v["pose_graph"]
    check(f"{name}: graph converged and lowered chi2",
          g["converged"] and g["final_chi2"] < 0.01 * g["initial_chi2"], g)
    after = v["reprojection_error_px"]["after_structure_only_ba"]
    corrected = v["reprojection_error_px"]["after_correction"]
    ba = v["structure_only_ba"]
    check(f"{name}: structure-only BA lowered its cost", ba["final_cost"] < ba["initial_cost"],
          (ba["initial_cost"], ba["final_cost"]))
    check(f"{name}: reprojection after < before (median, p90)",
          after["median"] < b["reprojection_error_px"]["median"]
          and after["p90"] < b["reprojection_error_px"]["p90"]
          and after["median"] < corrected["median"], (after["median"], after["p90"]))
sa = sim3["reprojection_error_px"]["after_structure_only_ba"]
ea = se3["reprojection_error_px"]["after_structure_only_ba"]
check("sim3 map more consistent than se3 (median and p90 after BA)",
      sa["median"] < ea["median"] and sa["p90"] < ea["p90"], (sa["median"], ea["median"]))
sys.exit(1 if failures else 0)
PY

# Bad input: one line, non-zero exit, no crash.
expect_error() {
  local status=0 message
  message="$("$bin" "$@" 2>&1 >/dev/null)" || status=$?
  [[ $status -ne 0 && $status -lt 128 && "$(wc -l <<< "$message")" == 1 ]] ||
    { echo "expected a one-line error for: $* (status $status: $message)" >&2; exit 1; }
  echo "ok   error for $*: $message"
}
expect_error keble --map "$out/does_not_exist.txt" --out "$out/bad"
expect_error keble --map "$out/summary.json" --out "$out/bad"
expect_error keble --out "$out/bad"
expect_error keble --map "$map" --out "$out/bad" --max-iterations 0
expect_error keble --map "$map" --out "$out/bad" --jacobians numeric
expect_error circles --out "$out/bad"
expect_error
echo "scale_drift_experiment keble: all checks passed"
