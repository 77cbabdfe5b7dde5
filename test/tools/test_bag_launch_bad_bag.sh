#!/usr/bin/env bash
# bag.launch with a bag that cannot be played (issue 17): a rendered bag cut in half (what a
# recording killed mid-way leaves) and a missing file. roslaunch must end by itself, with the
# player's reason (truncated or not indexed, `rosbag reindex`) and roslaunch's "REQUIRED process
# [player...] has died", instead of leaving the nodes idle forever. The watchdog (timeout 120 s)
# only turns a hang into a failure; a run takes ~5 s each.
set -euo pipefail
out="${SDS_TEST_OUTPUT_DIR:?}/bag_launch_bad_bag"
rm -rf "$out"
mkdir -p "$out"
export ROS_HOSTNAME=localhost
export ROS_HOME="$out/ros_home"
export ROS_LOG_DIR="$ROS_HOME/log"

"${SDS_BIN_DIR:?}/render_sequence" --scene office_orbit --frames 20 --out "$out/sequence" \
  --bag "$out/full.bag" --quiet
/usr/bin/python3 - "$out/full.bag" "$out/truncated.bag" <<'PY'
import os
import sys
size = os.path.getsize(sys.argv[1])
with open(sys.argv[1], 'rb') as full, open(sys.argv[2], 'wb') as cut:
    cut.write(full.read(size // 2))
PY

fail() {
  echo "FAIL: $*" >&2
  exit 1
}

# Runs bag.launch on $1 with its own master; checks it ends with the reason.
check() {
  local bag="$1" name="$2"
  local port log="$out/$name.log"
  port="$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("localhost", 0)); print(s.getsockname()[1])')"
  local status=0
  ROS_MASTER_URI="http://localhost:$port" timeout -s INT -k 10 120 \
    roslaunch -p "$port" scale_drift_slam bag.launch bag:="$bag" delay:=0.5 loop_closure:=false \
    > "$log" 2>&1 || status=$?
  [[ $status -ne 124 && $status -ne 137 ]] ||
    fail "$name: roslaunch did not end by itself (status $status, log $log)"
  grep -q "rosbag play failed: $bag" "$log" || fail "$name: no 'rosbag play failed: $bag' in $log"
  grep -q 'rosbag reindex BAG' "$log" || fail "$name: no 'rosbag reindex' hint in $log"
  grep -q 'REQUIRED process \[player' "$log" || fail "$name: roslaunch did not end the launch"
  echo "$name: roslaunch ended (status $status): $(grep -o 'rosbag play failed: [^.]*' "$log")"
}

check "$out/truncated.bag" truncated
check "$out/missing.bag" missing
echo "PASS"
