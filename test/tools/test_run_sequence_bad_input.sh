#!/usr/bin/env bash
# run_sequence on hostile files (issue 17, "Files and offline tools" rows), each row reproduced:
#   - a calibration with `D:`, `k1..p2` keys or Kalibr's camchain is read with its distortion
#     (the same camera line as our layout; the Kalibr run as accurate as our layout's);
#   - a misspelt `distortion_modle`, fx = 1e300: one-line errors, non-zero exit;
#   - every frame rejected (calibration for another size, all black): non-zero exit, the reason;
#   - 36 black frames: a young map is found again after them, one map;
#   - 36 black frames, then another place: a young map discarded when the new map starts there,
#     its poses in their own files, none lost, none mixed into trajectory.txt;
#   - a nan stamp: an error naming the line; reversed stamps: a warning, sorted outputs;
#   - 16-bit PNGs holding 12-bit data: test/system/test_sixteen_bit_sequence.cpp; here only
#     --bit-depth out of range;
#   - a truncated bag: the error suggests `rosbag reindex`.
# ~60 s.
set -euo pipefail
bin="${SDS_BIN_DIR:?}"
work="${SDS_TEST_OUTPUT_DIR:?}/run_sequence_bad_input"
rm -rf "$work"
mkdir -p "$work"
py=/usr/bin/python3

fail() { echo "FAIL: $*" >&2; exit 1; }

"$bin/render_sequence" --scene office_orbit --frames 90 --noise 1 --distortion radtan \
  --out "$work/office" --bag "$work/office.bag" --quiet

# The rendered camera.yaml (our layout) in the other layouts users have.
$py - "$work/office/camera.yaml" "$work" <<'PY'
import sys
c = {}
for line in open(sys.argv[1]):  # our layout, as render_sequence writes it
    if ":" in line and not line.startswith("#"):
        key, value = (x.strip() for x in line.split(":", 1))
        c[key] = [float(v) for v in value.strip("[]").split(",") if v.strip()] if value.startswith("[") \
            else (value if key == "distortion_model" else float(value))
c["width"], c["height"] = int(c["width"]), int(c["height"])
out = sys.argv[2]
d = c["distortion"]
head = "width: %d\nheight: %d\nfx: %r\nfy: %r\ncx: %r\ncy: %r\n" % (
    c["width"], c["height"], c["fx"], c["fy"], c["cx"], c["cy"])
open(out + "/calib_D.yaml", "w").write(head + "D: %r\n" % (d,))
keys = "".join("%s: %r\n" % (k, v) for k, v in zip(["k1", "k2", "p1", "p2", "k3"], d))
open(out + "/calib_k.yaml", "w").write(head + keys)
open(out + "/calib_kalibr.yaml", "w").write(
    "cam0:\n  camera_model: pinhole\n  intrinsics: [%r, %r, %r, %r]\n  resolution: [%d, %d]\n"
    "  distortion_model: radtan\n  distortion_coeffs: %r\n  rostopic: /cam0/image_raw\n"
    % (c["fx"], c["fy"], c["cx"], c["cy"], c["width"], c["height"], d[:4]))
open(out + "/calib_misspelt.yaml", "w").write(head + "distortion_modle: equidistant\n"
                                               "distortion: [0.01, 0.0, 0.0, 0.0]\n")
open(out + "/calib_huge_fx.yaml", "w").write(head.replace("fx: %r" % c["fx"], "fx: 1e300"))
open(out + "/calib_other_size.yaml", "w").write(
    head.replace("width: %d" % c["width"], "width: 752"))
assert len(d) >= 4 and any(abs(x) > 1e-3 for x in d), d
PY

camera_line() { grep '^camera:' "$1"; }
"$bin/run_sequence" "$work/office" --out "$work/own" --quiet > "$work/own.log" 2>&1 ||
  { cat "$work/own.log"; fail "run with the folder's calibration"; }
own_camera="$(camera_line "$work/own.log")"
for layout in D k; do  # the same camera as our layout: the distortion is read
  "$bin/run_sequence" "$work/office" --out "$work/x_$layout" --calib "$work/calib_$layout.yaml" \
    --max-frames 12 --quiet > "$work/$layout.log" 2>&1 || true
  [[ "$(camera_line "$work/$layout.log")" == "$own_camera" ]] ||
    fail "calib_$layout.yaml: '$(camera_line "$work/$layout.log")' != '$own_camera'"
done
"$bin/run_sequence" "$work/office" --out "$work/kalibr" --calib "$work/calib_kalibr.yaml" \
  --quiet > "$work/kalibr.log" 2>&1 || { cat "$work/kalibr.log"; fail "Kalibr calibration run"; }
grep -q '^camera: plumb_bob 640x480 .* d=\[-\?0\.[0-9]' "$work/kalibr.log" ||
  fail "Kalibr distortion not read: $(camera_line "$work/kalibr.log")"
for run in own kalibr; do
  "$bin/evaluate_trajectory" "$work/office/groundtruth.txt" "$work/$run/trajectory.txt" --json \
    > "$work/$run.json"
done
$py - "$work/own.json" "$work/kalibr.json" <<'PY'
import json, sys
own, kalibr = (json.load(open(f)) for f in sys.argv[1:])
r = lambda e: e["ate"]["rmse"] / e["ground_truth_path_length"]
print("ATE, our layout %.3f%%, Kalibr camchain %.3f%% of the path" % (100 * r(own), 100 * r(kalibr)))
assert r(kalibr) < 0.01 and r(kalibr) < 2 * r(own) + 0.002, (r(own), r(kalibr))
PY

expect_error() {  # what; expected text; command...
  local what="$1" expected="$2"
  shift 2
  if "$@" > "$work/error.log" 2>&1; then cat "$work/error.log"; fail "$what: exit 0"; fi
  grep -qF -- "$expected" "$work/error.log" || { cat "$work/error.log"; fail "$what: no '$expected'"; }
}
expect_error "misspelt key" "unknown key 'distortion_modle' (did you mean 'distortion_model'?)" \
  "$bin/run_sequence" "$work/office" --out "$work/x" --calib "$work/calib_misspelt.yaml"
expect_error "fx = 1e300" "more than 100x the 640x480 image" \
  "$bin/run_sequence" "$work/office" --out "$work/x" --calib "$work/calib_huge_fx.yaml"

# Every frame rejected: non-zero exit with the reason, the outputs written all the same.
expect_error "other image size" \
  "tracked nothing: all 20 frames were rejected: frame rejected: image is 640x480 but the calibration is 752x480 (20x)" \
  "$bin/run_sequence" "$work/office" --out "$work/other_size" --calib "$work/calib_other_size.yaml" \
  --max-frames 20 --quiet
[[ -s "$work/other_size/summary.json" ]] || fail "no summary.json after tracking nothing"
"$bin/render_sequence" --scene office_orbit --frames 10 --blackout 0:10 --out "$work/black" --quiet
expect_error "all black" "tracked nothing: all 10 frames were rejected: frame rejected: image has no texture" \
  "$bin/run_sequence" "$work/black" --out "$work/x" --quiet

# 36 black frames in the middle of the orbit: the young map is kept and found again after them.
"$bin/render_sequence" --scene office_orbit --frames 150 --noise 1 --blackout 1.2:1.2 \
  --out "$work/blackout" --quiet
"$bin/run_sequence" "$work/blackout" --out "$work/blackout_out" --quiet > "$work/blackout.log" 2>&1 ||
  { cat "$work/blackout.log"; fail "run with a blackout"; }
$py - "$work/blackout_out" <<'PY'
import csv, json, sys
out = sys.argv[1]
s = json.load(open(out + "/summary.json"))
frames = list(csv.DictReader(open(out + "/frames.csv")))
black = [int(f["frame"]) for f in frames if f["rejected"] == "1"]
after = [f for f in frames if int(f["frame"]) > max(black) and f["state"] in ("good", "weak")]
assert len(black) >= 30, len(black)
assert s["map_restarts"] == 0, "the young map was discarded: %s" % s["maps"]
assert len(after) >= 60, "not found again after the blackout: %d frames tracked" % len(after)
print("blackout: one map, %d frames tracked after the %d black ones" % (len(after), len(black)))
PY

# 36 black frames, then another place (the orbit with other textures): a new map starts there and
# the young map is discarded then; each map's poses in its own files.
"$bin/render_sequence" --scene office_orbit --frames 60 --noise 1 --out "$work/place_a" --quiet
"$bin/render_sequence" --scene office_orbit --frames 90 --noise 1 --seed 2 --blackout 0:1.2 \
  --start-time 1003 --out "$work/place_b" --quiet
mkdir -p "$work/restart/rgb"
cp "$work"/place_a/rgb/*.png "$work"/place_b/rgb/*.png "$work/restart/rgb/"
cp "$work/place_a/camera.yaml" "$work/restart/"
grep -h -v '^#' "$work/place_a/rgb.txt" "$work/place_b/rgb.txt" > "$work/restart/rgb.txt"
"$bin/run_sequence" "$work/restart" --out "$work/restart_out" --quiet > "$work/restart.log" 2>&1 ||
  { cat "$work/restart.log"; fail "run with a blackout and another place"; }
$py - "$work/restart_out" <<'PY'
import csv, json, os, sys
out = sys.argv[1]
s = json.load(open(out + "/summary.json"))
stamp = lambda f: [float(l.split()[0]) for l in open(os.path.join(out, f)) if l.strip() and not l.startswith("#")]
frames = list(csv.DictReader(open(out + "/frames.csv")))
black = [float(f["timestamp"]) for f in frames if f["rejected"] == "1"]
assert len(black) >= 30, len(black)
assert s["map_restarts"] >= 1, s["map_restarts"]
assert len(s["maps"]) == s["map_restarts"] + 1, s["maps"]
discarded = s["maps"][0]
assert discarded["discarded"] and discarded["trajectory"] == "trajectory_map0_discarded.txt"
old = stamp("trajectory_as_tracked_map0_discarded.txt")
old_corrected = stamp("trajectory_map0_discarded.txt")
new = stamp("trajectory_as_tracked.txt")
assert len(old) > 20 and old == old_corrected, (len(old), len(old_corrected))
assert all(t < min(black) for t in old), "the discarded map holds frames after the blackout"
assert len(new) > 20 and all(t > max(black) for t in stamp("trajectory.txt")), "trajectory.txt mixes the maps"
assert not set(old) & set(new), "a stamp in two maps"
assert sum(m["tracked"] for m in s["maps"]) == s["tracked"], s
maps = {f["map"] for f in frames}
assert maps == {str(k) for k in range(len(s["maps"]))}, maps
restart = next(f for f in frames if f["map"] == "1")
assert restart["state"] in ("good", "weak") and "young map" in restart["message"], restart
print("another place: map 0 %d poses (discarded at frame %s, where map 1 started), final map %d poses"
      % (len(old), restart["frame"], len(new)))
PY
grep -qF "trajectory[_as_tracked]_map0_discarded.txt" "$work/restart.log" || fail "the discarded map's files not named in the log"

# Stamps: nan is an error naming the line; reversed stamps are sorted with a warning.
cp -r "$work/office" "$work/nan"
sed -i '0,/^[0-9]/s/^[0-9.]* /nan /' "$work/nan/rgb.txt"
expect_error "nan stamp" "the timestamp 'nan' is not a finite number" \
  "$bin/run_sequence" "$work/nan" --out "$work/x" --quiet
grep -q "line [0-9]*:" "$work/error.log" || fail "nan stamp: no line number"
cp -r "$work/office" "$work/reversed"
{ grep '^#' "$work/office/rgb.txt" || true; grep -v '^#' "$work/office/rgb.txt" | tac; } \
  > "$work/reversed/rgb.txt"
"$bin/run_sequence" "$work/reversed" --out "$work/reversed_out" --quiet > "$work/reversed.log" 2>&1 ||
  { cat "$work/reversed.log"; fail "reversed stamps"; }
grep -q "timestamp(s) go back in time" "$work/reversed.log" || fail "reversed stamps: no warning"
$py - "$work/reversed_out/trajectory.txt" <<'PY'
import sys
t = [float(l.split()[0]) for l in open(sys.argv[1]) if l.strip() and not l.startswith("#")]
assert len(t) > 60 and t == sorted(set(t)), "trajectory not sorted or with repeated stamps"
PY

# 16-bit PNGs holding 12-bit data: test/system/test_sixteen_bit_sequence.cpp (no cv2 here);
# the option's range is checked here.
expect_error "bad --bit-depth" "mono16_bit_depth" \
  "$bin/run_sequence" "$work/office" --out "$work/x" --bit-depth 20

# A truncated bag: the error suggests rosbag reindex.
head -c "$(($(stat -c %s "$work/office.bag") / 2))" "$work/office.bag" > "$work/truncated.bag"
if "$bin/run_sequence" "$work/truncated.bag" --out "$work/truncated_out" --quiet \
  > "$work/truncated.log" 2>&1; then
  grep -q "rosbag reindex" "$work/truncated.log" || fail "truncated bag: read without a word"
else
  grep -q "rosbag reindex $work/truncated.bag" "$work/truncated.log" ||
    { cat "$work/truncated.log"; fail "truncated bag: no 'rosbag reindex' hint"; }
fi
echo "run_sequence bad input test passed"
