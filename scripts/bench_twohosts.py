#!/usr/bin/python3
"""The table of `scripts/bench twohosts`: one row per run of test/twohosts/two_hosts.sh --figures.
  bench_twohosts.py OUT.md RUN.json...   (each RUN.json's file name minus .json names its row)"""
import json
import os
import sys


def row(name, f):
    link = f.get('link', {}) if f['mode'] != 'one_host' else {}  # no link: every node local
    lat = f['pose_latency_ms']
    return ('| %s | %.1f | %.0f / %.0f / %.0f | %d x %.0f kB '
            '| %d x %.1f kB (median %.1f, max %.0f) | %s | %s | %s | %s |') % (
        name, f['tracking_rate_hz'], lat['median'], lat['p95'], lat['max'], f['keyframes'],
        f['keyframe_bytes']['mean'] / 1e3, f['map_updates'], f['map_update_bytes']['mean'] / 1e3,
        f['map_update_bytes']['median'] / 1e3, f['map_update_bytes']['max'] / 1e3,
        '%.2f / %.2f' % (link['robot_sent_mbit_s'], link['robot_received_mbit_s'])
        if link else '-',
        '%.2f' % f['loop_keyframe_to_correction_s'] if 'loop_keyframe_to_correction_s' in f
        else '-',
        '%.1f' % f['outage_catch_up_s'] if 'outage_catch_up_s' in f else '-',
        f.get('keyframes_during_outage', '-'))


def main():
    out, runs = sys.argv[1], sys.argv[2:]
    lines = ['| run | tracking rate (Hz) | pose latency median / p95 / max (ms) | keyframes x mean '
             'size | map updates x mean size | link robot -> base / base -> robot (Mbit/s) | loop '
             'keyframe -> correction at the robot (s) | catch-up after the outage (s) | keyframes '
             'during the outage |', '|' + '---|' * 9]
    shaping = []
    for run in runs:
        f = json.load(open(run))
        name = os.path.basename(run)[:-len('.json')]
        lines.append(row(name, f))
        shaping.append('- %s: %s%s' % (name, f['mode'], ', ' + f['shaping'] if f['mode'] !=
                                       'one_host' else ' (no link: every node in one namespace)'))
    text = '\n'.join(lines + [''] + shaping) + '\n'
    open(out, 'w').write(text)
    print(text)


if __name__ == '__main__':
    main()
