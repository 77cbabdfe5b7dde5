#!/usr/bin/env bash
# run_sequence end to end through its command line: a short rendered office_orbit clip as a TUM
# folder and as a rosbag must both be tracked after initialisation and give the outputs DESIGN.md
# names (trajectory.txt, keyframes.txt, summary.json with counts and per-stage timing); a folder
# with a corrupt frame still runs; bad input fails with one line and a non-zero exit; the
# trajectory is within 1% of the path (evaluate_trajectory). ~10 s.
set -euo pipefail
bin="${SDS_BIN_DIR:?}"
work="${SDS_TEST_OUTPUT_DIR:?}/run_sequence"
rm -rf "$work"
mkdir -p "$work"

fail() { echo "FAIL: $*" >&2; exit 1; }

"$bin/render_sequence" --scene office_orbit --frames 90 --noise 1 --out "$work/office" \
  --bag "$work/office.bag" --quiet

check_run() {  # folder-or-bag output-dir
  "$bin/run_sequence" "$1" --out "$2" --quiet > "$2.log" 2>&1 || { cat "$2.log"; fail "run on $1"; }
  for file in trajectory.txt keyframes.txt summary.json; do
    [[ -s "$2/$file" ]] || fail "$2/$file missing"
  done
  /usr/bin/python3 - "$2/summary.json" "$2/trajectory.txt" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
poses = [l for l in open(sys.argv[2]) if l.strip() and not l.startswith('#')]
assert s["frames"] == 90, s["frames"]
assert s["tracked"] == len(poses), (s["tracked"], len(poses))
assert s["tracked"] >= 75, "only %d of 90 frames tracked" % s["tracked"]
assert s["states"].get("lost", 0) == 0, s["states"]
assert s["keyframes"] >= 2 and s["points"] > 100, (s["keyframes"], s["points"])
assert s["loops"] == []
for stage in ("flow", "search", "motion_ba", "filters", "window_ba"):
    t = s["timing"][stage]
    assert 0 <= t["median_ms"] <= t["p95_ms"], (stage, t)
assert s["peak_memory_mib"] > 0 and s["startup_ms"] > 0
PY
}

check_run "$work/office" "$work/out_folder"
check_run "$work/office.bag" "$work/out_bag"
# Accuracy through the evaluation tool: ATE after Sim(3) alignment under 1% of the path.
"$bin/evaluate_trajectory" "$work/office/groundtruth.txt" "$work/out_folder/trajectory.txt" \
  --json > "$work/evaluation.json"
/usr/bin/python3 - "$work/evaluation.json" <<'PY'
import json, sys
e = json.load(open(sys.argv[1]))
ratio = e["ate"]["rmse"] / e["ground_truth_path_length"]
print("office_orbit 90 frames: ATE %.4f m = %.3f%% of the path" % (e["ate"]["rmse"], 100 * ratio))
assert ratio < 0.01, ratio
PY
grep -q "good" "$work/out_folder.log" || fail "no status counts printed"
grep -q "median ms" "$work/out_folder.log" || fail "no timing table printed"

# A corrupt image file in the middle is rejected, the run goes on.
cp -r "$work/office" "$work/corrupt"
victim="$(awk '!/^#/ {print $2}' "$work/corrupt/rgb.txt" | sed -n 50p)"
echo "not a png" > "$work/corrupt/$victim"
"$bin/run_sequence" "$work/corrupt" --out "$work/out_corrupt" --quiet > "$work/corrupt.log" 2>&1 ||
  { cat "$work/corrupt.log"; fail "corrupt frame ended the run"; }
grep -q "rejected" "$work/corrupt.log" || fail "corrupt frame not reported"

expect_error() {  # what; command...
  local what="$1"
  shift
  if "$@" > "$work/error.log" 2>&1; then fail "$what: accepted"; fi
  [[ "$(wc -l < "$work/error.log")" -eq 1 ]] || { cat "$work/error.log"; fail "$what: not one line"; }
  grep -q "run_sequence: error:" "$work/error.log" || fail "$what: no error line"
}
expect_error "missing dataset" "$bin/run_sequence" "$work/nothing" --out "$work/x"
expect_error "missing --out" "$bin/run_sequence" "$work/office"
expect_error "unknown flag" "$bin/run_sequence" "$work/office" --out "$work/x" --fast
mkdir -p "$work/nocalib" && cp "$work/office/rgb.txt" "$work/nocalib/"
expect_error "no calibration" "$bin/run_sequence" "$work/nocalib" --out "$work/x"
printf 'search:\n  min_ncc: 7\n' > "$work/bad.yaml"
expect_error "bad parameter" "$bin/run_sequence" "$work/office" --out "$work/x" --config "$work/bad.yaml"
expect_error "wrong bag topic" "$bin/run_sequence" "$work/office.bag" --out "$work/x" --topic /nope
"$bin/run_sequence" --help | grep -q "usage: run_sequence" || fail "--help"
echo "run_sequence tool test passed"
