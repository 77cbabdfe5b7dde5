#!/usr/bin/env bash
# Every launch file parses with its documented arguments and starts the nodes it promises, with the
# calibration and parameter files it names present; rviz/slam.rviz is valid YAML showing the map
# cloud, markers, path, tf and debug image. Needs no master. ~5 s.
set -euo pipefail
fail() { echo "FAIL: $*" >&2; exit 1; }
export ROS_HOME="${SDS_TEST_OUTPUT_DIR:?}/launch_files_ros_home"
mkdir -p "$ROS_HOME"
pkg="$(rospack find scale_drift_slam)"

check() {  # "expected nodes" launch-file [args...]
  local expected="$1"
  shift
  local nodes params
  nodes="$(roslaunch --nodes scale_drift_slam "$@" 2>&1 | sort | tr '\n' ' ')" || fail "$*: $nodes"
  [[ "$nodes" == "$expected " ]] || fail "$*: nodes '$nodes', expected '$expected '"
  params="$(roslaunch --dump-params scale_drift_slam "$@" 2>&1)" || fail "$*: $params"
  for file in $(grep -oE "(calibration_file|config): /[^ ,}']+" <<< "$params" | awk '{print $2}'); do
    [[ -f "$file" ]] || fail "$*: names a missing file $file"
  done
  echo "$params"
}

check "/mapping_node /tracking_node" slam.launch > /dev/null
check "/mapping_node /rviz /tracking_node" slam.launch rviz:=true > /dev/null
params="$(check "/mapping_node /player /tracking_node" bag.launch bag:=/some.bag)"
grep -q "use_sim_time: true" <<< "$params" || fail "bag.launch does not use simulated time"
check "/mapping_node /play_sequence /tracking_node" demo.launch > /dev/null
params="$(check "/mapping_node /tracking_node" euroc.launch)"
grep -q "euroc_cam0.yaml" <<< "$params" || fail "euroc.launch calibration"
check "/mapping_node /player /tracking_node" euroc.launch bag:=/MH_01_easy.bag > /dev/null
for camera in fr1 fr2 fr3; do
  params="$(check "/mapping_node /player /tracking_node" tum.launch camera:=$camera bag:=/x.bag)"
  grep -q "tum_$camera.yaml" <<< "$params" || fail "tum.launch camera:=$camera calibration"
done

/usr/bin/python3 - "$pkg/rviz/slam.rviz" <<'PY'
import sys, yaml
config = yaml.safe_load(open(sys.argv[1]))
displays = config["Visualization Manager"]["Displays"]
topics = {d.get("Topic") or d.get("Marker Topic") or d.get("Image Topic") for d in displays}
classes = {d["Class"] for d in displays}
for topic in ("/map_cloud", "/map_markers", "/path", "/debug_image"):
    assert topic in topics, "rviz config shows no " + topic
assert "rviz/TF" in classes, classes
assert config["Visualization Manager"]["Global Options"]["Fixed Frame"] == "map"
PY
echo "launch files test passed"
