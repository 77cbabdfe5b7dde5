#!/usr/bin/python3
"""A user-space stand-in for tc netem's delay and loss, for kernels without sch_netem
(two_hosts.sh). Runs in a namespace of its own between two veth ends and forwards every Ethernet
frame from one to the other after a fixed delay, dropping each with a given probability, in
order. Raw packet sockets with virtio-net headers (PACKET_VNET_HDR) carry the kernel's checksum
and segmentation state along with each frame, so frames of checksum-offloading veths arrive
valid. The rate limit stays in the kernel (tc tbf on the two outer ends).

  link_emulator.py --delay-ms 30 --loss 0.01 IFACE_1 IFACE_2

Prints "ready" once both sockets are bound, and on SIGTERM/SIGINT what it did: frames and bytes
each way, frames dropped, and how late frames left against their due time (the emulator is a
process on a shared machine: its delay is 30 ms plus that lateness).
"""

import argparse
import heapq
import random
import select
import signal
import socket
import sys
import time

SOL_PACKET = 263
PACKET_VNET_HDR = 15
PACKET_IGNORE_OUTGOING = 23
PACKET_OUTGOING = 4
ETH_P_ALL = 0x0003


def open_socket(interface):
    s = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETH_P_ALL))
    s.setsockopt(SOL_PACKET, PACKET_VNET_HDR, 1)
    try:
        s.setsockopt(SOL_PACKET, PACKET_IGNORE_OUTGOING, 1)
    except OSError:
        pass  # old kernel: outgoing frames are filtered by their packet type below
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 << 20)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 8 << 20)
    s.bind((interface, 0))
    s.setblocking(False)
    return s


class Stats(object):
    def __init__(self):
        self.frames = [0, 0]
        self.bytes = [0, 0]
        self.dropped = [0, 0]
        self.send_errors = 0
        self.lateness = []

    def report(self, delay_ms, loss):
        late = sorted(self.lateness) or [0.0]
        return ('link emulator (delay %.0f ms, loss %.1f %%): %d frames / %d bytes one way, '
                '%d / %d the other; dropped %d and %d; %d send errors; lateness against the due '
                'time: median %.2f ms, 99th percentile %.2f ms, max %.2f ms' % (
                    delay_ms, 100 * loss, self.frames[0], self.bytes[0], self.frames[1],
                    self.bytes[1], self.dropped[0], self.dropped[1], self.send_errors,
                    1e3 * late[len(late) // 2], 1e3 * late[int(0.99 * (len(late) - 1))],
                    1e3 * late[-1]))


def run(sockets, delay, loss, stats, stop):
    queue = []  # (due, sequence, direction, frame)
    sequence = 0
    rng = random.Random()
    while not stop:
        timeout = max(0.0, queue[0][0] - time.monotonic()) if queue else 0.5
        readable, _, _ = select.select(sockets, [], [], timeout)
        now = time.monotonic()
        for s in readable:
            direction = sockets.index(s)
            while True:
                try:
                    frame, address = s.recvfrom(70000)
                except (BlockingIOError, InterruptedError):
                    break
                if address[2] == PACKET_OUTGOING:
                    continue
                if rng.random() < loss:
                    stats.dropped[direction] += 1
                    continue
                heapq.heappush(queue, (now + delay, sequence, direction, frame))
                sequence += 1
        now = time.monotonic()
        while queue and queue[0][0] <= now:
            due, _, direction, frame = heapq.heappop(queue)
            try:
                sockets[1 - direction].send(frame)
                stats.frames[direction] += 1
                stats.bytes[direction] += len(frame) - 10  # without the virtio-net header
                stats.lateness.append(now - due)
            except OSError:
                stats.send_errors += 1


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument('--delay-ms', type=float, default=30.0)
    parser.add_argument('--loss', type=float, default=0.01)
    parser.add_argument('interfaces', nargs=2)
    args = parser.parse_args()
    sockets = [open_socket(i) for i in args.interfaces]
    stats, stop = Stats(), []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    signal.signal(signal.SIGINT, lambda *_: stop.append(1))
    print('ready', flush=True)
    try:
        run(sockets, args.delay_ms / 1e3, args.loss, stats, stop)
    except InterruptedError:
        pass
    print(stats.report(args.delay_ms, args.loss), flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
