#!/usr/bin/env bash
# evaluate_trajectory: known scale and offset recovered (TUM and EuRoC input), JSON, --out and
# --plot outputs, and one-line errors for missing files, malformed lines and bad flags.
set -euo pipefail
bin="$SDS_BIN_DIR/evaluate_trajectory"
out="$SDS_TEST_OUTPUT_DIR/tool_evaluate_trajectory"
rm -rf "$out" && mkdir -p "$out"
fail() { echo "FAIL: $*" >&2; exit 1; }

# Ground truth: a circle of radius 5 m; estimate: scaled by 0.5 and shifted, with +-2 cm
# alternating height errors (ATE 2 cm after Sim(3) alignment), every second frame only; the
# same estimate as EuRoC csv (nanoseconds, position, quaternion w x y z).
/usr/bin/python3 - "$out" <<'PY'
import math, sys
out = sys.argv[1]
with open(out + '/truth.txt', 'w') as t, open(out + '/estimate.txt', 'w') as e, open(out + '/estimate.csv', 'w') as c:
    t.write('# timestamp tx ty tz qx qy qz qw\n')
    c.write('#timestamp [ns], p_x, p_y, p_z, q_w, q_x, q_y, q_z\n')
    for i in range(400):
        a = 2 * math.pi * i / 400
        x, y, z = 5 * math.cos(a), 5 * math.sin(a), 0.0
        qz, qw = math.sin(a / 2), math.cos(a / 2)
        stamp = 1000 + 0.05 * i
        t.write('%.6f %.9f %.9f %.9f 0 0 %.12f %.12f\n' % (stamp, x, y, z, qz, qw))
        if i % 2 == 0:
            dz = 0.02 if (i // 2) % 2 else -0.02
            ex, ey, ez = 0.5 * x + 3, 0.5 * y - 1, 0.5 * (z + dz) + 7
            e.write('%.6f %.9f %.9f %.9f 0 0 %.12f %.12f\n' % (stamp + 0.003, ex, ey, ez, qz, qw))
            c.write('%d,%.9f,%.9f,%.9f,%.12f,0,0,%.12f\n' % (round((stamp + 0.003) * 1e9), ex, ey, ez, qw, qz))
PY

check_json() {
  /usr/bin/python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
assert d["frames"]["tracked"] == 200 and d["frames"]["ground_truth"] == 400, d["frames"]
assert abs(d["frames"]["tracked_fraction"] - 0.5) < 1e-12
assert abs(d["alignment_transform"]["scale"] - 2.0) < 1e-3, d["alignment_transform"]
assert abs(d["ate"]["rmse"] - 0.02) < 1e-3, d["ate"]
assert all(abs(s["scale"] - 1) < 2e-3 for s in d["scale_segments"]), d["scale_segments"]
assert [r["distance"] for r in d["rpe"]] == [1, 2, 5, 10]
' "$1"
}
"$bin" "$out/truth.txt" "$out/estimate.txt" --json > "$out/tum.json"
check_json "$out/tum.json"
"$bin" "$out/truth.txt" "$out/estimate.csv" --out "$out/euroc" --plot "$out/plot.png" > "$out/summary.txt"
check_json "$out/euroc/evaluation.json"
[[ -s "$out/plot.png" && -s "$out/euroc/evaluation.png" ]] || fail "no plot"
grep -q '^ATE  rmse 0.02' "$out/summary.txt" || fail "summary lacks the ATE: $(cat "$out/summary.txt")"
grep -q 'frames tracked      200 of 400' "$out/summary.txt" || fail "summary lacks the frame count"
# SE(3) alignment keeps the wrong scale: a large error.
"$bin" "$out/truth.txt" "$out/estimate.txt" --align se3 --json |
  /usr/bin/python3 -c 'import json,sys; d=json.load(sys.stdin); assert d["ate"]["rmse"] > 1.0 and d["alignment"] == "se3"'

expect_error() {
  local expected="$1"; shift
  set +e; "$bin" "$@" > /dev/null 2> "$out/err.txt"; local status=$?; set -e
  [[ $status -ne 0 ]] || fail "exit 0 for: $*"
  [[ $(wc -l < "$out/err.txt") == 1 ]] || fail "not one line for: $* ($(cat "$out/err.txt"))"
  grep -q -- "$expected" "$out/err.txt" || fail "'$expected' not in: $(cat "$out/err.txt")"
}
printf '1000.0 1 2 3 0 0 0 1\n1000.1 1 2 oops 0 0 0 1\n' > "$out/malformed.txt"
: > "$out/empty.txt"
expect_error "cannot open" "$out/missing.txt" "$out/estimate.txt"
expect_error "line 2" "$out/truth.txt" "$out/malformed.txt"
expect_error "holds no poses" "$out/truth.txt" "$out/empty.txt"
expect_error "alignment must be sim3 or se3" "$out/truth.txt" "$out/estimate.txt" --align affine
expect_error "missing argument: ESTIMATE" "$out/truth.txt"
expect_error "within 0.001" "$out/truth.txt" "$out/estimate.txt" --max-dt 0.001
expect_error "RPE distances" "$out/truth.txt" "$out/estimate.txt" --rpe-distances 1,-2
"$bin" --help | grep -q 'usage: evaluate_trajectory' || fail "--help"
echo "evaluate_trajectory tool test passed"
