#!/usr/bin/env bash
# Every launch file parses with its documented arguments and starts the nodes it promises (the three
# SLAM nodes), with the calibration and parameter files it names present; rviz/slam.rviz is valid
# YAML showing the map cloud, markers (loop edges included), path, tf and debug image. Loads them
# with roslaunch's own loader (no master, no process started). ~3 s.
set -euo pipefail
export ROS_HOME="${SDS_TEST_OUTPUT_DIR:?}/launch_files_ros_home"
mkdir -p "$ROS_HOME"
/usr/bin/python3 - "$(rospack find scale_drift_slam)" <<'PY'
import os
import sys

import roslaunch.config
import yaml

pkg = sys.argv[1]


def load(name, *args):
    """Nodes (sorted names) and parameters of a launch file with arguments."""
    config = roslaunch.config.load_config_default(
        [(os.path.join(pkg, 'launch', name), list(args))], None, verbose=False)
    nodes = sorted(n.namespace.rstrip('/') + '/' + n.name for n in config.nodes)
    params = {key: p.value for key, p in config.params.items()}
    for key, value in params.items():  # every file a launch file names exists
        if key.endswith(('/calibration_file', '/config')) and value:
            assert os.path.isfile(value), '%s %s: %s = %s is missing' % (name, args, key, value)
    return nodes, params


def check(expected, name, *args):
    nodes, params = load(name, *args)
    assert nodes == sorted(expected), '%s %s: nodes %s, expected %s' % (name, args, nodes, expected)
    return params


slam = ['/loop_closure_node', '/mapping_node', '/tracking_node']
params = check(slam, 'slam.launch')
assert params['/tracking_node/calibration_file'] == ''
assert params['/tracking_node/map_frame'] == 'map'
assert params['/loop_closure_node/config'] == params['/tracking_node/config']
check(['/loop_closure_node', '/mapping_node', '/rviz', '/tracking_node'], 'slam.launch',
      'rviz:=true')
check(['/mapping_node', '/tracking_node'], 'slam.launch', 'loop_closure:=false')
check(['/mapping_node', '/player', '/tracking_node'], 'bag.launch', 'bag:=/some.bag',
      'loop_closure:=false')
check(['/mapping_node', '/play_sequence', '/tracking_node'], 'demo.launch', 'loop_closure:=false')
check(['/mapping_node', '/tracking_node'], 'euroc.launch', 'loop_closure:=false')
check(['/mapping_node', '/tracking_node'], 'tum.launch', 'loop_closure:=false')
params = check(slam + ['/player'], 'bag.launch', 'bag:=/some.bag')
assert params['/use_sim_time'] is True, 'bag.launch does not use simulated time'
assert params['/tracking_node/image_queue_size'] == 100
params = check(['/loop_closure_node', '/mapping_node', '/play_sequence', '/tracking_node'],
               'demo.launch')
assert params['/use_sim_time'] is True
params = check(slam, 'euroc.launch')
assert params['/tracking_node/calibration_file'].endswith('config/euroc_cam0.yaml')
assert '/use_sim_time' not in params
check(slam + ['/player'], 'euroc.launch', 'bag:=/MH_01_easy.bag')
for camera in ('fr1', 'fr2', 'fr3'):
    params = check(slam + ['/player'], 'tum.launch',
                   'camera:=' + camera, 'bag:=/x.bag')
    assert params['/tracking_node/calibration_file'].endswith('config/tum_%s.yaml' % camera)

# A map file reaches the three nodes; localisation only the tracker; saving the mapper.
params = check(slam + ['/player'], 'bag.launch', 'bag:=/some.bag', 'map_file:=/m.map',
               'localization_only:=true', 'save_map_on_shutdown:=/out.map')
for node in slam:
    assert params[node + '/map_file'] == '/m.map', node
assert params['/tracking_node/localization_only'] is True
assert params['/mapping_node/save_map_on_shutdown'] == '/out.map'
params = check(slam, 'slam.launch')
assert params['/tracking_node/localization_only'] is False
assert params['/mapping_node/save_map_on_shutdown'] is False

# Two machines: each side's nodes get the network environment of their machine.
euroc = os.path.join(pkg, 'config', 'euroc_cam0.yaml')
params = check(['/tracking_node'], 'robot.launch', 'master_uri:=http://10.0.0.1:11311',
               'address:=10.0.0.2', 'image:=/cam0/image_raw', 'calibration_file:=' + euroc,
               'map_file:=/m.map', 'localization_only:=true')
assert params['/tracking_node/calibration_file'] == euroc
assert params['/tracking_node/map_file'] == '/m.map'
assert params['/tracking_node/localization_only'] is True
assert params['/tracking_node/keyframe_publish_queue_size'] == 200
params = check(['/keyframe_relay', '/loop_closure_node', '/mapping_node'], 'base_station.launch',
               'master_uri:=http://10.0.0.1:11311', 'address:=10.0.0.1', 'map_file:=/m.map')
assert params['/mapping_node/map_file'] == params['/loop_closure_node/map_file'] == '/m.map'
check(['/loop_closure_node', '/mapping_node'], 'base_station.launch', 'relay_keyframes:=false')
for name, address, node in (('robot.launch', '10.0.0.2', 'tracking_node'),
                            ('base_station.launch', '10.0.0.1', 'mapping_node')):
    config = roslaunch.config.load_config_default(
        [(os.path.join(pkg, 'launch', name),
          ['master_uri:=http://10.0.0.1:11311', 'address:=' + address])], None, verbose=False)
    n = next(n for n in config.nodes if n.name == node)
    env = dict(n.env_args)
    assert env == {'ROS_MASTER_URI': 'http://10.0.0.1:11311', 'ROS_IP': address,
                   'ROS_HOSTNAME': address}, '%s: %s' % (name, env)
    if node == 'mapping_node':
        assert ['keyframes', '/base_station/keyframes'] in list(map(list, n.remap_args)), \
            n.remap_args
    else:
        assert ['image', '/camera/image_raw'] in list(map(list, n.remap_args)), n.remap_args

config = yaml.safe_load(open(os.path.join(pkg, 'rviz', 'slam.rviz')))
displays = config['Visualization Manager']['Displays']
topics = {d.get('Topic') or d.get('Marker Topic') or d.get('Image Topic') for d in displays}
for topic in ('/map_cloud', '/map_markers', '/path', '/debug_image'):
    assert topic in topics, 'rviz config shows no ' + topic
assert 'rviz/TF' in {d['Class'] for d in displays}
markers = next(d for d in displays if d.get('Marker Topic') == '/map_markers')
assert markers['Namespaces'].get('loop_edges') is True, 'rviz config hides the loop edges'
assert config['Visualization Manager']['Global Options']['Fixed Frame'] == 'map'
print('launch files test passed')
PY
