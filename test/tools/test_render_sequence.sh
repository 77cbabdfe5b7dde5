#!/usr/bin/env bash
# render_sequence: writes a TUM folder and a bag with the same frames and stamps, is deterministic
# for a seed, and refuses bad input with one line and a non-zero exit code.
set -euo pipefail
bin="$SDS_BIN_DIR/render_sequence"
out="$SDS_TEST_OUTPUT_DIR/tool_render_sequence"
rm -rf "$out" && mkdir -p "$out"
fail() { echo "FAIL: $*" >&2; exit 1; }

"$bin" --scene corridor_straight --out "$out/a" --bag "$out/a.bag" --frames 6 --width 160 \
  --height 120 --distortion fisheye --noise 2 --seed 4 --quiet > "$out/a.log"
for f in rgb.txt groundtruth.txt camera.yaml; do [[ -s "$out/a/$f" ]] || fail "missing $f"; done
[[ $(grep -vc '^#' "$out/a/rgb.txt") == 6 ]] || fail "rgb.txt does not list 6 frames"
[[ $(grep -vc '^#' "$out/a/groundtruth.txt") == 6 ]] || fail "groundtruth.txt does not hold 6 poses"
[[ $(ls "$out/a/rgb" | wc -l) == 6 ]] || fail "not 6 images"
grep -q 'distortion_model: equidistant' "$out/a/camera.yaml" || fail "camera.yaml lacks the fisheye model"

# The bag: the same stamps as rgb.txt on every topic, and the same poses as groundtruth.txt.
/usr/bin/python3 - "$out/a.bag" "$out/a/rgb.txt" "$out/a/groundtruth.txt" <<'PY'
import sys, rosbag
bag_path, rgb_path, gt_path = sys.argv[1:4]
stamps = [l.split()[0] for l in open(rgb_path) if l.strip() and not l.startswith('#')]
truth = [l.split() for l in open(gt_path) if l.strip() and not l.startswith('#')]
seen = {}
def fmt(t): return "%d.%09d" % (t.secs, t.nsecs)
for topic, msg, t in rosbag.Bag(bag_path).read_messages():
    stamp = msg.transforms[0].header.stamp if topic == '/tf' else msg.header.stamp
    seen.setdefault(topic, []).append(fmt(stamp))
    assert fmt(t) == fmt(stamp), "bag time differs from the header stamp on %s" % topic
    if topic == '/ground_truth/pose':
        row = truth[len(seen[topic]) - 1]
        p = msg.pose.position
        assert abs(p.x - float(row[1])) < 1e-9 and abs(p.z - float(row[3])) < 1e-9, "pose differs"
    if topic == '/camera/image_raw':
        assert msg.encoding == 'mono8' and msg.width == 160 and msg.height == 120
    if topic == '/camera/camera_info':
        assert msg.distortion_model == 'equidistant'
for topic in ['/camera/image_raw', '/camera/camera_info', '/ground_truth/pose', '/tf']:
    assert seen.get(topic) == stamps, "stamps on %s differ from rgb.txt: %s" % (topic, seen.get(topic))
print("bag matches the folder: %d frames on 4 topics" % len(stamps))
PY

# Deterministic for a seed; another seed gives other images.
"$bin" --scene corridor_straight --out "$out/b" --frames 6 --width 160 --height 120 \
  --distortion fisheye --noise 2 --seed 4 --quiet > /dev/null
"$bin" --scene corridor_straight --out "$out/c" --frames 6 --width 160 --height 120 \
  --distortion fisheye --noise 2 --seed 5 --quiet > /dev/null
diff -r "$out/a" "$out/b" > /dev/null || fail "same seed, different output"
! diff -r "$out/a/rgb" "$out/c/rgb" > /dev/null || fail "different seeds, same images"

# Ground truth scored against itself: zero error.
"$SDS_BIN_DIR/evaluate_trajectory" "$out/a/groundtruth.txt" "$out/a/groundtruth.txt" --json |
  /usr/bin/python3 -c 'import json,sys; d=json.load(sys.stdin); assert d["ate"]["rmse"] < 1e-9 and d["frames"]["tracked"] == 6'

# Bad input: one line on stderr, non-zero exit.
expect_error() {
  local expected="$1"; shift
  set +e; "$bin" "$@" > /dev/null 2> "$out/err.txt"; local status=$?; set -e
  [[ $status -ne 0 ]] || fail "exit 0 for: $*"
  [[ $(wc -l < "$out/err.txt") == 1 ]] || fail "not one line for: $* ($(cat "$out/err.txt"))"
  grep -q -- "$expected" "$out/err.txt" || fail "'$expected' not in: $(cat "$out/err.txt")"
}
expect_error "unknown scene 'moon_base'" --scene moon_base --out "$out/x"
expect_error "cannot create output folder" --scene office_orbit --out /proc/forbidden --frames 1
expect_error "expects a number" --scene office_orbit --out "$out/x" --noise loud
expect_error "unknown flag --nosie" --scene office_orbit --out "$out/x" --nosie 3
expect_error "distortion must be" --scene office_orbit --out "$out/x" --distortion barrel
expect_error "START:LENGTH" --scene office_orbit --out "$out/x" --blackout 3
expect_error "missing required flag --scene" --out "$out/x"
expect_error "fps must be > 0" --scene office_orbit --out "$out/x" --fps -5
"$bin" --help | grep -q 'usage: render_sequence' || fail "--help"
echo "render_sequence tool test passed"
