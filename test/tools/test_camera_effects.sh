#!/usr/bin/env bash
# Real camera effects of render_sequence (issue 16, item 4; doc/sequences.md): for each effect a
# short rendered sequence must be tracked end to end by run_sequence, >= 95 % of the frames from
# the first pose on, with the ATE (Sim(3)) <= 1 % of the path: rolling shutter (30 ms readout,
# every row at its own pose), vignetting, auto-exposure over sunlit patches that clip (with the
# scene's brightness changing), JPEG at quality 75 (bgr8 with noise, as compressed image_transport
# delivers), defocus, motion blur (a 20 ms shutter at 30 Hz, orbiting an office), all of them at
# once, and the repetitive facade_grid scene (front end and mapping: its loop closure is pending,
# see pending_facade_grid_loops.sh). ~1.5 min.
set -euo pipefail
bin="${SDS_BIN_DIR:?}"
work="${SDS_TEST_OUTPUT_DIR:?}/camera_effects"
checks="$(dirname "${BASH_SOURCE[0]}")/effects_checks.py"
rm -rf "$work"
mkdir -p "$work"

fail() { echo "FAIL: $*" >&2; exit 1; }

# check NAME SCENE FRAMES "RUN_SEQUENCE FLAGS" RENDER_FLAGS...
check() {
  local name="$1" scene="$2" frames="$3" run_flags="$4"
  shift 4
  "$bin/render_sequence" --scene "$scene" --frames "$frames" --out "$work/$name" --quiet "$@" \
    > "$work/$name.render.log" 2>&1 || { cat "$work/$name.render.log"; fail "render $name"; }
  # shellcheck disable=SC2086
  "$bin/run_sequence" "$work/$name" --out "$work/$name.run" --quiet $run_flags \
    > "$work/$name.run.log" 2>&1 || { cat "$work/$name.run.log"; fail "run_sequence on $name"; }
  "$bin/evaluate_trajectory" "$work/$name/groundtruth.txt" "$work/$name.run/trajectory.txt" \
    --json > "$work/$name.evaluation.json"
  /usr/bin/python3 "$checks" "$name" "$work/$name.run/frames.csv" "$work/$name.evaluation.json"
}

check rolling_shutter courtyard_loop 300 "" --rolling-shutter 0.03
check vignetting office_orbit 300 "" --vignetting 0.6
check auto_exposure courtyard_loop 300 "" --auto-exposure --exposure 0.3 --exposure-period 4 \
  --noise 1
check jpeg office_orbit 300 "" --jpeg 75 --color --noise 1
check defocus office_orbit 300 "" --defocus 3
check motion_blur office_orbit 300 "" --motion-blur 0.02 --noise 1
check all_effects courtyard_loop 300 "" --rolling-shutter 0.03 --vignetting 0.4 --auto-exposure \
  --defocus 1.5 --noise 1 --jpeg 80
check facade_grid facade_grid 600 --no-loop-closure

# Bad values are refused with one line.
for bad in "--motion-blur 2" "--rolling-shutter -1" "--vignetting 1" "--jpeg 0" "--jpeg 101" "--defocus 50" \
           "--sunlight 0.5"; do
  # shellcheck disable=SC2086
  if "$bin/render_sequence" --scene desk --out "$work/bad" $bad > "$work/bad.log" 2>&1; then
    fail "render_sequence accepted $bad"
  fi
  [[ "$(wc -l < "$work/bad.log")" -eq 1 ]] || { cat "$work/bad.log"; fail "$bad: not one line"; }
done
echo "camera effects tool test passed"
