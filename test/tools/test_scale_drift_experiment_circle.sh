#!/usr/bin/env bash
# scale_drift_experiment circle and sphere: the outputs exist, the summaries show the paper's
# outcome (Sim(3) corrects a loop with scale drift better than SE(3)), --runs and --noise-sweep
# write what they promise, and bad input gives a one-line error. About 10 s.
#  - circle, 1 px, seed 1 (the full 720 poses take ~0.5 s): scale change at the loop +25 %,
#    RMSE SE(3) 1.04, Sim(3) 0.18 (checked: Sim(3) < SE(3) / 2, the loop scale > 10 %);
#  - sphere with 3 great circles (4 loops): SE(3) 1.02, Sim(3) 0.16.
set -euo pipefail
bin="${SDS_BIN_DIR:?}/scale_drift_experiment"
out="${SDS_TEST_OUTPUT_DIR:?}/scale_drift_experiment_circle"
rm -rf "$out"

"$bin" --help | grep -q "circle --out DIR"
"$bin" circle --out "$out/circle" --noise 1.0 --seed 1
"$bin" circle --out "$out/runs" --runs 2 --seed 4
"$bin" circle --out "$out/sweep" --noise-sweep
"$bin" sphere --out "$out/sphere" --revolutions 3
for f in summary.json truth.tum before.tum se3.tum sim3.tum circle_top_view.png; do
  for d in circle runs runs/run_00 runs/run_01; do
    [[ -s "$out/$d/$f" ]] || { echo "missing output $d/$f" >&2; exit 1; }
  done
done
for f in summary.json truth.tum before.tum se3.tum sim3.tum sphere_top_view.png; do
  [[ -s "$out/sphere/$f" ]] || { echo "missing output sphere/$f" >&2; exit 1; }
done
[[ -s "$out/sweep/summary.json" && -s "$out/sweep/noise_sweep.png" ]] ||
  { echo "missing noise sweep outputs" >&2; exit 1; }
[[ "$(grep -vc '^#' "$out/circle/sim3.tum")" == 720 ]] || { echo "sim3.tum needs 720 frames" >&2; exit 1; }

/usr/bin/python3 - "$out" <<'PY'
import json, sys
out = sys.argv[1]
failures = []
def check(name, ok, value):
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {value}")
    if not ok:
        failures.append(name)
c = json.load(open(f"{out}/circle/summary.json"))
e = c["error"]
check("circle: 720 frames, one loop edge", c["map"]["frames"] == 720 and c["graph"]["loop_edges"] == 1,
      (c["map"]["frames"], c["graph"]))
check("circle: Sim(3) error < SE(3) error / 2",
      e["sim3"]["position_rmse"] < 0.5 * e["se3"]["position_rmse"],
      (e["se3"]["position_rmse"], e["sim3"]["position_rmse"]))
check("circle: SE(3) error < error before", e["se3"]["position_rmse"] < e["before"]["position_rmse"],
      (e["before"]["position_rmse"], e["se3"]["position_rmse"]))
loop = c["loops"][0]
check("circle: the loop is last -> first keyframe",
      loop["loop_keyframe"] == 0 and loop["current_keyframe"] == c["map"]["keyframes"] - 1, loop)
check("circle: scale drift > 10 % at the loop", abs(loop["measured_scale_change_percent"]) > 10,
      loop["measured_scale_change_percent"])
check("circle: measured loop scale within 2 % of the map's",
      abs(loop["measured_scale"] / loop["true_scale"] - 1) < 0.02,
      (loop["measured_scale"], loop["true_scale"]))
check("circle: run time recorded", c["time_s"]["total_cpu"] > 0, c["time_s"])
r = json.load(open(f"{out}/runs/summary.json"))
check("runs: 2 runs with seeds 4, 5 and their mean/median",
      [x["seed"] for x in r["runs"]] == [4, 5] and r["aggregate"]["runs"] == 2
      and "median" in r["aggregate"]["sim3_rmse"], r["aggregate"]["sim3_rmse"])
s = json.load(open(f"{out}/sweep/summary.json"))
levels = s["levels"]
check("sweep: noise 0 .. 1.2 px", [l["noise_px"] for l in levels] == [0, 0.2, 0.4, 0.6, 0.8, 1.0, 1.2],
      [l["noise_px"] for l in levels])
drift = [l["aggregate"]["max_loop_scale_change_percent"]["mean"] for l in levels]
check("sweep: the scale drift grows with the noise (0 px < 0.4 px < 1.2 px)",
      drift[0] < drift[2] < drift[6], drift)
check("sweep: no error without noise", levels[0]["aggregate"]["sim3_rmse"]["mean"] < 0.01,
      levels[0]["aggregate"]["sim3_rmse"])
sp = json.load(open(f"{out}/sphere/summary.json"))
check("sphere: 4 loops detected", sp["graph"]["loop_edges"] == 4, sp["graph"])
check("sphere: Sim(3) error < SE(3) error",
      sp["error"]["sim3"]["position_rmse"] < sp["error"]["se3"]["position_rmse"], sp["error"])
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
expect_error circle --out "$out/bad" --noise -1
expect_error circle --out "$out/bad" --unknown-flag 3
expect_error circle --out "$out/bad" --noise abc
expect_error circle --out "$out/bad" --runs 0
expect_error circle --out "$out/bad" --poses 2
expect_error circle --out "$out/bad" --noise 1 --noise-sweep
expect_error circle --noise 1
expect_error sphere --out "$out/bad" --noise -0.5
expect_error sphere --out "$out/bad" --revolutions 0
expect_error sphere --out "$out/bad" --poses 100
echo "scale_drift_experiment circle/sphere: all checks passed"
