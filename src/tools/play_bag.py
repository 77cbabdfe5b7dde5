#!/usr/bin/python3
"""play_bag: `rosbag play` for the launch files (bag.launch, euroc.launch, tum.launch), watched.

Runs `rosbag play` with the arguments given (those of rosbag play). When the bag cannot be played
(missing, truncated or not indexed: checked by opening it first; or rosbag play fails on the way,
which it reports with a FATAL line but exit status 0) it says so with the way out and exits
non-zero: the launch files start it with required="true", so roslaunch ends the
whole launch instead of leaving the nodes idle forever. When the bag ends normally the nodes keep
running (e.g. for ~save_trajectory) until Ctrl-C."""

import signal
import subprocess
import sys
import threading

import rosbag
import rospy


def bag_of(arguments):
    """The bag files among rosbag play's arguments (for the message)."""
    return [a for a in arguments if a.endswith('.bag') or a.endswith('.bag.active')]


def unreadable(bags):
    """Why one of `bags` cannot be played ('' when they open)."""
    for bag in bags:
        try:
            with rosbag.Bag(bag, 'r'):
                pass
        except Exception as e:  # IOError, ROSBagUnindexedException, ROSBagFormatException...
            return '%s cannot be opened (%s: %s)' % (bag, type(e).__name__, e)
    return ''


def relay_errors(stream, fatal):
    """Copies rosbag play's stderr to ours; notes its FATAL lines (it still exits with 0)."""
    for raw in iter(stream.readline, b''):
        line = raw.decode('utf-8', 'replace')
        sys.stderr.write(line)
        sys.stderr.flush()
        if 'FATAL' in line:
            fatal.append(line.strip())


def fail(reason):
    rospy.logfatal(
        'rosbag play failed: %s. The bag is missing, truncated or not indexed (a recording that '
        'was cut off: `rosbag reindex BAG` recovers most of it, then play it again). Ending the '
        'launch: the nodes would wait forever.', reason)
    return 1


def main():
    arguments = rospy.myargv(sys.argv)[1:]
    rospy.init_node('player', disable_signals=True)
    bags = bag_of(arguments)
    problem = unreadable(bags)
    if problem:
        return fail(problem)
    player = subprocess.Popen(['rosbag', 'play'] + arguments, stdin=subprocess.DEVNULL,
                              stderr=subprocess.PIPE)
    fatal = []
    relay = threading.Thread(target=relay_errors, args=(player.stderr, fatal), daemon=True)
    relay.start()

    def stop(*_):
        if player.poll() is None:
            player.send_signal(signal.SIGINT)
        rospy.signal_shutdown('stopped')

    signal.signal(signal.SIGINT, stop)
    signal.signal(signal.SIGTERM, stop)
    status = player.wait()
    relay.join(timeout=2.0)
    if rospy.is_shutdown():
        return 0
    names = ' '.join(bags) or '(no .bag file given)'
    if status != 0 or fatal:
        return fail('%s, exit status %d%s' % (names, status, ': ' + fatal[0] if fatal else ''))
    rospy.loginfo('the bag %s ended; the nodes keep running (Ctrl-C ends the launch)', names)
    while not rospy.is_shutdown():
        signal.pause()  # until SIGINT/SIGTERM (the simulated clock has stopped: no rospy.sleep)
    return 0


if __name__ == '__main__':
    sys.exit(main())
