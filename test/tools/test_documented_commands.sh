#!/usr/bin/env bash
# Every command of the ```bash blocks of README.md and doc/ros.md, run as documented (issue 17:
# `rosrun scale_drift_slam mapping_node` after scripts/test said "Couldn't find executable"):
# - rosrun of each node: it starts and is still up (and registered) 4 s later, then stopped;
# - roslaunch of each launch file, headless (rviz:=false), bags replaced by a rendered one, the
#   placeholder calibration by config/euroc_cam0.yaml: the three nodes come up and stay up;
# - rosservice call of ~save_trajectory while bag.launch plays: success, keyframes written;
# - each command-line tool: `rosrun scale_drift_slam TOOL --help` prints its usage (their runs
#   are tested by the other test/tools tests);
# - `source build/devel/setup.bash`: the file is there.
# What cannot run here is printed with the reason (scripts/test runs this test; scripts/demo is
# the long demo; the catkin-workspace build is a second full build; rostest files run in ctest).
# A documented command this test does not know fails it: nothing is skipped silently.
# One master on a free port; ~70 s.
set -euo pipefail
out="${SDS_TEST_OUTPUT_DIR:?}/documented_commands"
rm -rf "$out"
mkdir -p "$out"
export ROS_HOSTNAME=localhost
export ROS_HOME="$out/ros_home"
export ROS_LOG_DIR="$ROS_HOME/log"
root="$(rospack find scale_drift_slam)"
"${SDS_BIN_DIR:?}/render_sequence" --scene office_orbit --frames 60 --out "$out/sequence" \
  --bag "$out/sequence.bag" --quiet
exec /usr/bin/python3 - "$root" "$out" <<'PY'
import os
import re
import shlex
import signal
import socket
import subprocess
import sys
import time

root, out = sys.argv[1], sys.argv[2]
bag = os.path.join(out, 'sequence.bag')
NODES = ['tracking_node', 'mapping_node', 'loop_closure_node']
TOOLS = ['render_sequence', 'run_sequence', 'evaluate_trajectory', 'detect_loops',
         'scale_drift_experiment']
failures = []


def documented_commands(path):
    """The commands of the ```bash blocks (continuations joined, comments and [optional] args
    dropped), with their line numbers."""
    commands, block, pending = [], False, ''
    with open(path) as f:
        for number, line in enumerate(f, 1):
            if line.startswith('```'):
                block = line.strip() == '```bash' if not block else False
                continue
            if not block:
                continue
            pending += line.rstrip('\n')
            if pending.endswith('\\'):
                pending = pending[:-1] + ' '
                continue
            text = re.sub(r'\[[^\]]*\]', ' ', pending)  # [optional arguments]
            pending = ''
            words = shlex.split(text, comments=True)
            if words:
                commands.append(('%s:%d' % (os.path.basename(path), number), words))
    return commands


def free_port():
    s = socket.socket()
    s.bind(('localhost', 0))
    port = s.getsockname()[1]
    s.close()
    return port


def rosnodes():
    """The nodes registered with the master (rosgraph's API: rosnode is not a dependency)."""
    import rosgraph
    try:
        publishers, subscribers, services = rosgraph.Master('/doc_test').getSystemState()
    except Exception:
        return []
    return sorted({n for _, nodes in publishers + subscribers + services for n in nodes})


def stop(process, grace=30):
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=grace)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def wait_for_nodes(names, process, seconds):
    """True when every one of `names` is registered while `process` still runs."""
    deadline = time.time() + seconds
    while time.time() < deadline:
        if process.poll() is not None:
            return False
        if all('/' + n in rosnodes() for n in names):
            return True
        time.sleep(1.0)
    return False


def check(where, ok, what):
    print('%-16s %s %s' % (where, 'ok  ' if ok else 'FAIL', what), flush=True)
    if not ok:
        failures.append('%s: %s' % (where, what))


def run_rosrun(where, words):
    package, executable = words[1], words[2]
    log = open(os.path.join(out, 'rosrun_%s.log' % executable), 'w')
    process = subprocess.Popen(words, stdout=log, stderr=subprocess.STDOUT)
    up = wait_for_nodes([executable], process, 20)
    time.sleep(4.0)
    alive = process.poll() is None
    stop(process)
    check(where, up and alive, '`%s`: started, registered, still up 4 s later' % ' '.join(words))


def headless(words):
    """The launch command with rviz off, the bags replaced, the placeholder calibration real."""
    result, notes = [], []
    for w in words:
        key, _, value = w.partition(':=')
        if key == 'rviz' and value == 'true':
            w = 'rviz:=false'
        elif key == 'bag':
            w = 'bag:=' + bag
        elif key == 'master_uri':  # another machine's master: this test's, on this host
            w = 'master_uri:=' + os.environ['ROS_MASTER_URI']
        elif key == 'address':
            w = 'address:=127.0.0.1'
        elif key == 'map_file' and value.startswith('/tmp/'):  # where save_map wrote it here
            w = 'map_file:=' + os.path.join(out, value[len('/tmp/'):])
        elif key == 'calibration_file' and not os.path.exists(value):
            w = 'calibration_file:=' + os.path.join(root, 'config', 'euroc_cam0.yaml')
        if w != words[len(result)]:
            notes.append(w.split(':=')[0])
        result.append(w)
    if words[2] == 'demo.launch':  # a short rendering of the demo's scene, in the output folder
        result += ['frames:=60', 'bag:=' + os.path.join(out, 'demo.bag')]
        notes.append('frames, bag')
    return result, notes


def run_roslaunch(where, words, services):
    command, notes = headless(words)
    log = open(os.path.join(out, 'roslaunch_%s.log' % words[2]), 'w')
    process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT)
    expected = NODES if 'loop_closure:=false' not in words else NODES[:2]
    if words[2] == 'robot.launch':  # the two-machine split (doc/ros.md, "Running on two machines")
        expected = ['tracking_node']
    elif words[2] == 'base_station.launch':
        expected = [n for n in NODES[1:] if n != 'loop_closure_node' or
                    'loop_closure:=false' not in words]
    up = wait_for_nodes(expected, process, 60)
    time.sleep(8.0 if services else 4.0)
    for service_where, service_words in services:
        run_rosservice(service_where, service_words)
    alive = process.poll() is None and all('/' + n in rosnodes() for n in expected)
    stop(process)
    changed = ' (changed: %s)' % ', '.join(notes) if notes else ''
    check(where, up and alive, '`%s`%s: the nodes came up and stayed up' %
          (' '.join(words), changed))


def run_rosservice(where, words):
    command = [w.replace('/tmp/', out + '/') for w in words]
    result = subprocess.run(command, capture_output=True, text=True, timeout=60)
    path = re.search(r"path: '([^']*)'", ' '.join(command))
    if path and 'save_map' in words[2]:  # a map file: its magic (doc/map_file.md)
        written = os.path.exists(path.group(1)) and \
            open(path.group(1), 'rb').read(8) == b'SDSMAP\r\n'
    else:  # keyframes, TUM
        written = path and os.path.exists(path.group(1)) and any(
            not line.startswith('#') for line in open(path.group(1)))
    check(where, result.returncode == 0 and 'success: True' in result.stdout and bool(written),
          '`%s` during bag.launch: %s' % (' '.join(words), result.stdout.strip().replace('\n', '; ')))


def run_tool_help(where, tool):
    result = subprocess.run(['rosrun', 'scale_drift_slam', tool, '--help'], capture_output=True,
                            text=True, timeout=60)
    text = result.stdout + result.stderr
    check(where, result.returncode == 0 and 'usage' in text.lower(),
          '`rosrun scale_drift_slam %s --help`: %s' % (tool, text.strip().splitlines()[0]
                                                       if text.strip() else 'no output'))


def not_run(where, words, reason):
    print('%-16s not run: `%s`: %s' % (where, ' '.join(words), reason), flush=True)


commands = documented_commands(os.path.join(root, 'README.md')) + \
    documented_commands(os.path.join(root, 'doc', 'ros.md'))
port = free_port()
os.environ['ROS_MASTER_URI'] = 'http://localhost:%d' % port
master = subprocess.Popen(['roscore', '-p', str(port)], stdout=open(os.path.join(out, 'roscore.log'), 'w'),
                          stderr=subprocess.STDOUT)
try:
    deadline = time.time() + 30
    while not rosnodes():
        assert time.time() < deadline, 'roscore did not start'
        time.sleep(0.5)
    services = [(w, c) for w, c in commands if c[0] == 'rosservice']
    workspace = False
    done = {}  # command -> (where it ran, failures it left)
    for where, words in commands:
        first = words[0]
        key = tuple(words)
        if key in done and first not in ('mkdir', 'cd', 'git', 'catkin_make', 'source'):
            earlier, failed = done[key]
            check(where, not failed, '`%s`: the same command as %s' % (' '.join(words), earlier))
            continue
        before = len(failures)
        if first == 'mkdir' and 'catkin_ws' in ' '.join(words):
            workspace = True
        if workspace and first in ('mkdir', 'cd', 'git', 'catkin_make', 'source'):
            not_run(where, words, 'building in a catkin workspace is a second full build '
                    '(~20 min on 2 cores); the package builds the same way here')
            workspace = first != 'source'
            continue
        if first == 'scripts/test':
            not_run(where, words, 'it runs ctest, which runs this test')
        elif first == 'scripts/demo':
            not_run(where, words, 'the full demo (~2 min); it starts demo.launch, run below')
        elif first == 'source':  # (or the build folder's, when SDS_BUILD_DIR moved it)
            setup = os.path.join(os.environ['SDS_BIN_DIR'], '..', '..', 'setup.bash')
            check(where, os.path.isfile(os.path.join(root, words[1])) or (
                  words[1] == 'build/devel/setup.bash' and os.path.isfile(setup)),
                  '`source %s`: the file is there' % words[1])
        elif first == 'rosrun' and words[1] == 'scale_drift_slam' and words[2] in NODES:
            run_rosrun(where, words)
        elif first == 'roslaunch' and words[1] == 'scale_drift_slam':
            run_roslaunch(where, words, services if words[2] == 'bag.launch' else [])
            if words[2] == 'bag.launch':
                services = []
        elif first == 'rosservice':
            pass  # called while bag.launch plays (above)
        elif first == 'rostest' and words[1] == 'scale_drift_slam':
            registered = os.path.isfile(os.path.join(root, 'test', 'rostest', words[2]))
            check(where, registered, '`%s`: run by ctest (test/rostest/%s, registered by '
                  'cmake/tests.cmake), not again here' % (' '.join(words), words[2]))
        elif first in TOOLS:
            run_tool_help(where, first)
        elif first == 'export' and all(
                w.startswith(('ROS_MASTER_URI=', 'ROS_IP=')) for w in words[1:]):
            not_run(where, words, "one machine's environment; the two-machine tests (ctest "
                    "twohosts_*) set it per network namespace, and the launch commands run here "
                    "with this test's master")
        elif words == ['roscore', '&']:
            not_run(where, words, 'the master; this test runs its own (roscore on a free port)')
        elif 'ctest -R twohosts' in ' '.join(words):
            registered = 'twohosts' in open(os.path.join(root, 'cmake', 'tests.cmake')).read()
            check(where, registered, '`%s`: the twohosts tests are registered in '
                  'cmake/tests.cmake and run by ctest' % ' '.join(words))
        elif 'test/twohosts/two_hosts.sh' in words:
            script = os.path.join(root, 'test', 'twohosts', 'two_hosts.sh')
            check(where, os.path.isfile(script), '`%s`: a ~1 min experiment with a 15 s outage; '
                  'ctest twohosts_outage runs the same script with 5 s' % ' '.join(words))
        else:
            check(where, False, '`%s`: a documented command this test does not know: teach it'
                  % ' '.join(words))
        done[key] = (where, len(failures) > before)
    if services:
        check(services[0][0], False, 'rosservice documented without bag.launch to run it in')
finally:
    stop(master)

print('%d commands, %d failures' % (len(commands), len(failures)))
for failure in failures:
    print('FAIL: ' + failure)
sys.exit(1 if failures else 0)
PY
