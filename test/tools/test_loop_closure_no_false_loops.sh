#!/usr/bin/env bash
# No false loop: run_sequence on corridor_straight (a long forward walk that never comes back,
# with identical posters and periodic ceiling panels) and office_orbit (a wobbly orbit in a
# furnished room), three seeds each. Every loop accepted must join keyframes whose true cameras
# stand within 3 m and look within 30 degrees of each other; the corridor has no true loop at all.
# ~1.5 min.
set -euo pipefail
bin="${SDS_BIN_DIR:?}"
checks="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)/loop_checks.py"
work="${SDS_TEST_OUTPUT_DIR:?}/loop_closure_no_false_loops"
rm -rf "$work"
mkdir -p "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }
printf "system:\n  mapping_thread: false\n" > "$work/inline.yaml"

for scene in corridor_straight office_orbit; do
  for seed in 1 2 3; do
    name="${scene}_$seed"
    "$bin/render_sequence" --scene "$scene" --noise 1 --seed "$seed" --out "$work/$name" --quiet
    "$bin/run_sequence" "$work/$name" --out "$work/$name.out" --config "$work/inline.yaml" \
      --quiet > "$work/$name.log" 2>&1 || { cat "$work/$name.log"; fail "run_sequence on $name"; }
    echo "$name: $(grep "loops closed" "$work/$name.log")"
    /usr/bin/python3 "$checks" loops "$work/$name.out/summary.json" "$work/$name/groundtruth.txt"
    if [[ "$scene" == corridor_straight ]]; then
      /usr/bin/python3 -c "import json,sys; assert json.load(open(sys.argv[1]))['loops'] == []" \
        "$work/$name.out/summary.json" || fail "$name: a loop in a corridor that never comes back"
    fi
    rm -rf "$work/$name"  # the images: keep the test folder small
  done
done
echo "PASS"
