#!/usr/bin/env bash
# The SLAM on two "machines" (issue 20): two network namespaces joined by a veth pair, the robot
# (namespace A, 10.200.0.1: tracking_node via launch/robot.launch, the bag player, the checker)
# and the base station (namespace B, 10.200.0.2: the ROS master, mapping_node and
# loop_closure_node via launch/base_station.launch), each side with ROS_MASTER_URI / ROS_IP /
# ROS_HOSTNAME set as a user sets them on two machines. The link is shaped in both directions:
# 30 ms delay, 1 % loss, 20 Mbit/s, by tc netem where the kernel has sch_netem; else (said on the
# output) by tc tbf for the rate and link_emulator.py, a user-space forwarder in a third namespace
# between the two, for the delay and loss (TWO_HOSTS_EMULATOR=false: the rate only). With
# --outage S the link is cut for S seconds mid-run (every packet dropped both ways: a pfifo of
# length 0 on both ends, the link itself stays up).
# two_hosts_check.py plays courtyard_loop on the robot side and asserts: every frame tracked, the
# loop closed, ATE within 0.5 % of the path, every keyframe the tracker published in the mapper's
# map (~save_trajectory), no keyframe gap reported by the mapper.
#
# Usage: two_hosts.sh [--outage SECONDS] [--one-host] [--figures FILE]
#   --one-host   everything in namespace A on its own address (the bench's baseline, no link)
#   --figures    write the measured figures (JSON) there (scripts/bench twohosts)
# OUTAGE_AFTER: seconds into the bag when the outage starts (10).
# TWO_HOSTS_ROBOT_ARGS / TWO_HOSTS_BASE_ARGS: more arguments of robot.launch / base_station.launch
# (experiments, e.g. keyframe_publish_queue_size:=20, relay_keyframes:=false).
# Exits 77 (ctest SKIP_RETURN_CODE) with "SKIP: why" where namespaces cannot be made (not root,
# no `ip netns`, no veth). Namespaces and every process in them are removed on any exit.
set -uo pipefail

outage=0
one_host=false
figures=""
while [[ $# -gt 0 ]]; do
  case "$1" in
    --outage) outage="$2"; shift 2 ;;
    --one-host) one_host=true; shift ;;
    --figures) figures="$2"; shift 2 ;;
    *) echo "usage: $0 [--outage SECONDS] [--one-host] [--figures FILE]" >&2; exit 2 ;;
  esac
done

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
skip() { echo "SKIP: $*"; exit 77; }
log() { echo "[two_hosts $(date -u +%H:%M:%S)] $*"; }

[[ "$(id -u)" == 0 ]] || skip "network namespaces need root (running as uid $(id -u))"
command -v ip >/dev/null || skip "no 'ip' command (iproute2)"
command -v tc >/dev/null || skip "no 'tc' command (iproute2)"
command -v roslaunch >/dev/null ||
  { echo "FAIL: roslaunch not found: run with the devel env.sh"; exit 1; }

tag="$$"
ns_a="sds_robot_$tag"
ns_b="sds_base_$tag"
ns_link="sds_link_$tag"  # the link emulator's, without netem
dev_a="sdsr$tag"
dev_b="sdsb$tag"
addr_a=10.200.0.1
addr_b=10.200.0.2
port=11311  # the namespaces have their own ports: no clash with other masters
run_name="$([[ $one_host == true ]] && echo one_host || echo "outage$outage")"
out="${SDS_TEST_OUTPUT_DIR:-$PWD}/two_hosts_$run_name"
export ROS_HOME="${ROS_HOME:-${SDS_TEST_OUTPUT_DIR:-$PWD}/two_hosts_ros_home}"
rm -rf "$out" && mkdir -p "$out"
export ROS_LOG_DIR="$out/log"

namespaces=("$ns_a" "$ns_b")
cleanup() {
  local status=$?
  trap - EXIT INT TERM
  [[ -n "${outage_pid:-}" ]] && kill "$outage_pid" 2>/dev/null
  for ns in "${namespaces[@]}"; do
    ip netns pids "$ns" 2>/dev/null | while read -r pid; do kill -INT "$pid" 2>/dev/null; done
  done
  sleep 2
  for ns in "${namespaces[@]}"; do
    ip netns pids "$ns" 2>/dev/null | while read -r pid; do kill -KILL "$pid" 2>/dev/null; done
    ip netns del "$ns" 2>/dev/null
  done
  [[ -s "$out/link_emulator.log" ]] && log "$(tail -n 1 "$out/link_emulator.log")"
  log "namespaces ${namespaces[*]} removed"
  exit "$status"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# Namespaces a killed run of this script left (its pid is gone): their processes were its own.
for stale in $(ip netns list 2>/dev/null | grep -oE '^sds_(robot|base|link)_[0-9]+'); do
  kill -0 "${stale##*_}" 2>/dev/null && continue
  ip netns pids "$stale" | while read -r pid; do kill -KILL "$pid" 2>/dev/null; done
  ip netns del "$stale" && log "removed $stale, left by a run that was killed"
done
ip netns add "$ns_a" 2>"$out/netns.err" ||
  skip "cannot create a network namespace: $(cat "$out/netns.err")"
ip netns add "$ns_b" || skip "cannot create a second network namespace"
ip -n "$ns_a" link set lo up && ip -n "$ns_b" link set lo up || exit 1

# The link: tc netem on both ends where the kernel has it; else tc tbf (the rate) on both ends
# and, between them in a third namespace, link_emulator.py (the delay and the loss).
netem="netem delay 30ms loss 1% rate 20mbit limit 10000"
tbf="tbf rate 20mbit burst 32kb latency 400ms"
if ip netns exec "$ns_a" tc qdisc add dev lo root $netem 2>"$out/tc.err"; then
  ip netns exec "$ns_a" tc qdisc del dev lo root
  shaping="$netem" emulate=false
  describe="tc qdisc $netem on both ends"
else
  log "tc netem is not available here ($(tr -d '\n' <"$out/tc.err") - the kernel has no sch_netem)"
  shaping="$tbf" emulate="${TWO_HOSTS_EMULATOR:-true}"
  describe="tc qdisc $tbf on both ends (the rate)"
  if [[ $emulate == true ]]; then
    describe+=", link_emulator.py in $ns_link: 30 ms delay and 1 % loss each way (user space)"
  else
    describe+=": NO added delay, NO random loss (TWO_HOSTS_EMULATOR=false)"
  fi
fi
if [[ $emulate == true ]]; then
  namespaces+=("$ns_link")
  ip netns add "$ns_link" || exit 1
  ip link add "$dev_a" netns "$ns_a" type veth peer name "sdsx$tag" netns "$ns_link" \
    2>"$out/veth.err" ||
    skip "cannot create a veth pair: $(cat "$out/veth.err")"
  ip link add "$dev_b" netns "$ns_b" type veth peer name "sdsy$tag" netns "$ns_link" || exit 1
  ip -n "$ns_link" link set "sdsx$tag" up && ip -n "$ns_link" link set "sdsy$tag" up || exit 1
  # One frame per TCP segment, so that the emulator's loss is per packet.
  ip -n "$ns_a" link set "$dev_a" gso_max_segs 1 && ip -n "$ns_b" link set "$dev_b" gso_max_segs 1
  ip netns exec "$ns_link" /usr/bin/python3 "$here/link_emulator.py" --delay-ms 30 --loss 0.01 \
    "sdsx$tag" "sdsy$tag" >"$out/link_emulator.log" 2>&1 &
  for _ in $(seq 1 50); do grep -q ready "$out/link_emulator.log" && break; sleep 0.2; done
  grep -q ready "$out/link_emulator.log" || { cat "$out/link_emulator.log"; exit 1; }
else
  ip link add "$dev_a" netns "$ns_a" type veth peer name "$dev_b" netns "$ns_b" 2>"$out/veth.err" ||
    skip "cannot create a veth pair: $(cat "$out/veth.err")"
fi
ip -n "$ns_a" addr add "$addr_a/30" dev "$dev_a" &&
  ip -n "$ns_b" addr add "$addr_b/30" dev "$dev_b" &&
  ip -n "$ns_a" link set "$dev_a" up && ip -n "$ns_b" link set "$dev_b" up || exit 1

shape() {  # the egress of each end
  ip netns exec "$ns_a" tc qdisc replace dev "$dev_a" root $shaping &&
    ip netns exec "$ns_b" tc qdisc replace dev "$dev_b" root $shaping
}
cut_link() {  # every packet dropped both ways; the interfaces stay up (a radio dropout)
  ip netns exec "$ns_a" tc qdisc replace dev "$dev_a" root pfifo limit 0 &&
    ip netns exec "$ns_b" tc qdisc replace dev "$dev_b" root pfifo limit 0
}
shape || exit 1
log "link $addr_a ($ns_a) <-> $addr_b ($ns_b): $describe"

run_in() {  # run_in NS ADDRESS command...: one side's ROS environment, as on its own machine
  local ns="$1" address="$2"
  shift 2
  ip netns exec "$ns" env ROS_MASTER_URI="http://$master_addr:$port" ROS_IP="$address" \
    ROS_HOSTNAME="$address" "$@"
}

master_ns="$ns_b" master_addr="$addr_b" base_ns="$ns_b" base_addr="$addr_b"
if [[ $one_host == true ]]; then
  master_ns="$ns_a" master_addr="$addr_a" base_ns="$ns_a" base_addr="$addr_a"
fi

run_in "$master_ns" "$master_addr" roscore -p "$port" >"$out/roscore.log" 2>&1 &
for _ in $(seq 1 60); do
  run_in "$ns_a" "$addr_a" rosparam set /use_sim_time true >/dev/null 2>&1 && break
  sleep 1
done
run_in "$ns_a" "$addr_a" rosparam get /use_sim_time >/dev/null 2>&1 ||
  { echo "FAIL: the master at http://$master_addr:$port is not reachable from $ns_a"; exit 1; }
log "master up at http://$master_addr:$port ($master_ns)"
if [[ $one_host == false && ( $emulate == true || $shaping == netem* ) ]]; then
  # The link delays: a TCP handshake with the master takes a round trip (>= 60 ms), never less.
  rtt_ms="$(run_in "$ns_a" "$addr_a" /usr/bin/python3 -c '
import socket, sys, time
times = []
for _ in range(5):
    start = time.monotonic()
    socket.create_connection((sys.argv[1], int(sys.argv[2])), timeout=10).close()
    times.append(time.monotonic() - start)
print("%.1f" % (1e3 * min(times)))' "$master_addr" "$port")"
  log "round trip robot -> base station (TCP handshake, best of 5): $rtt_ms ms"
  /usr/bin/python3 -c "import sys; sys.exit(float(sys.argv[1]) < 55.0)" "${rtt_ms:-0}" ||
    { echo "FAIL: the link does not delay (round trip $rtt_ms ms, expected >= 60 ms)"; exit 1; }
fi

run_in "$base_ns" "$base_addr" roslaunch scale_drift_slam base_station.launch \
  master_uri:="http://$master_addr:$port" address:="$base_addr" output:=log \
  ${TWO_HOSTS_BASE_ARGS:-} \
  >"$out/base_station.log" 2>&1 &
run_in "$ns_a" "$addr_a" roslaunch scale_drift_slam robot.launch \
  master_uri:="http://$master_addr:$port" address:="$addr_a" image_queue_size:=100 output:=log \
  ${TWO_HOSTS_ROBOT_ARGS:-} \
  >"$out/robot.log" 2>&1 &

if [[ "$outage" != 0 ]]; then
  (  # OUTAGE_AFTER s after the bag starts playing (the checker touches $out/playing)
    while [[ ! -e "$out/playing" ]]; do sleep 0.2; done
    sleep "${OUTAGE_AFTER:-10}"
    cut_link && echo "cut $(date +%s.%N)" >>"$out/outage.txt"
    sleep "$outage"
    shape && echo "restored $(date +%s.%N)" >>"$out/outage.txt"
  ) &
  outage_pid=$!
fi

checker=(/usr/bin/python3 "$here/two_hosts_check.py" --out "$out" --outage "$outage")
[[ -n "$figures" ]] && checker+=(--figures "$figures" --link-device "$dev_a"
  --mode "$([[ $one_host == true ]] && echo one_host || echo two_hosts)" --shaping "$describe")
run_in "$ns_a" "$addr_a" "${checker[@]}" 2>&1 | tee "$out/check.log"
status=${PIPESTATUS[0]}
if [[ $status != 0 ]]; then
  log "FAILED ($status); node logs under $ROS_LOG_DIR, launch output in $out"
  tail -n 20 "$out/robot.log" "$out/base_station.log"
  # The verdict again, last: a CI log that keeps only the end of the output still shows why.
  grep -E '^(FAIL|two hosts)' "$out/check.log" | sed 's/^/[two_hosts verdict] /'
fi
exit "$status"
