"""A link emulator for test networks: bad Wi-Fi between machines that are Linux network namespaces.

This kernel has no ``netem`` qdisc, so the "air" between the machines is this small user-space hub instead:
it runs in the air namespace, holds one end of each machine's veth pair (an AF_PACKET socket per port) and
passes every Ethernet frame on to the other ports, each direction of a machine's link with its own delay,
jitter, loss and cut. Frames are real frames: ARP, TCP with its retransmissions, UDP, ICMP, exactly what the
machines' kernels send.

    ip netns exec air python -m tests.netshaper --control /tmp/x.sock l_laptop l_robot1 l_robot2

Control: JSON datagrams on the unix socket, ``{"port": "l_robot1", "delay_ms": 20, "jitter_ms": 10,
"loss": 0.05, "cut": false}`` (any subset; "port": "*" for all), answered with the counters of every port.
"""

from __future__ import annotations

import argparse
import contextlib
import heapq
import json
import os
import random
import select
import socket
import struct
import threading
import time
from dataclasses import asdict, dataclass, field
from typing import Any

ETH_P_ALL = 0x0003
SOL_PACKET = 263
PACKET_STATISTICS = 6  # struct tpacket_stats {unsigned tp_packets, tp_drops}, reset on every read
PACKET_IGNORE_OUTGOING = 23


@dataclass
class LinkState:
    """How the air treats frames going to and coming from one machine."""

    delay_ms: float = 0.0
    jitter_ms: float = 0.0
    loss: float = 0.0
    cut: bool = False
    frames_in: int = 0
    frames_out: int = 0
    dropped: int = 0  # by the shaping: loss, cut
    send_errors: int = 0  # the hub could not pass a frame on (not the link's doing)
    missed: int = 0  # frames the kernel dropped before the hub read them (its receive buffer was full)
    frames_from: dict[str, int] = field(default_factory=dict)  # by source MAC, for captures in tests


class Hub:
    def __init__(self, ports: list[str], seed: int = 1) -> None:
        self.ports = ports
        self.links = {p: LinkState() for p in ports}
        self.sockets: dict[str, socket.socket] = {}
        for port in ports:
            s = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETH_P_ALL))
            s.bind((port, 0))
            with contextlib.suppress(OSError):  # Linux >= 4.20: our own sends never fill the receive buffer
                s.setsockopt(SOL_PACKET, PACKET_IGNORE_OUTGOING, 1)
            s.setblocking(False)
            self.sockets[port] = s
        self.by_fd = {s.fileno(): p for p, s in self.sockets.items()}
        self.queue: list[tuple[float, int, str, bytes]] = []
        self.lock = threading.Condition()
        self.random = random.Random(seed)
        self.seq = 0

    def _latency(self, link: LinkState) -> float:
        jitter = self.random.uniform(-link.jitter_ms, link.jitter_ms) if link.jitter_ms else 0.0
        return max(0.0, link.delay_ms + jitter) / 1000.0

    def receive(self) -> None:
        poller = select.epoll()
        for fd in self.by_fd:
            poller.register(fd, select.EPOLLIN)
        while True:
            for fd, _ in poller.poll():
                port = self.by_fd[fd]
                sock = self.sockets[port]
                while True:
                    try:
                        frame, address = sock.recvfrom(65535)
                    except BlockingIOError:
                        break
                    if address[2] == socket.PACKET_OUTGOING:
                        continue  # our own sends on this port
                    self._take(port, frame)

    def _take(self, source: str, frame: bytes) -> None:
        now = time.monotonic()
        up = self.links[source]
        up.frames_in += 1
        if up.cut or (up.loss and self.random.random() < up.loss):
            up.dropped += 1
            return
        with self.lock:
            for port in self.ports:
                if port == source:
                    continue
                down = self.links[port]
                if down.cut or (down.loss and self.random.random() < down.loss):
                    down.dropped += 1
                    continue
                # both halves of the path: the sender's link up to the air, the receiver's link down from it
                due = now + self._latency(up) + self._latency(down)
                self.seq += 1
                heapq.heappush(self.queue, (due, self.seq, port, frame))
            self.lock.notify()

    def send(self) -> None:
        while True:
            with self.lock:
                while not self.queue or self.queue[0][0] > time.monotonic():
                    self.lock.wait(None if not self.queue else max(0.0, self.queue[0][0] - time.monotonic()))
                _, _, port, frame = heapq.heappop(self.queue)
            link = self.links[port]
            if link.cut:  # cut while the frame was in the air
                link.dropped += 1
                continue
            try:
                self.sockets[port].send(frame)
                # by source and destination MAC and EtherType (0806 ARP, 0800 IPv4, 86dd IPv6): "no packet to the
                # robot but ARP" is checkable, and multicast (IPv6 neighbour discovery) is told from unicast
                source = f"{frame[6:12].hex(':')}>{frame[0:6].hex(':')}/{frame[12:14].hex()}"
                with self.lock:
                    link.frames_out += 1
                    link.frames_from[source] = link.frames_from.get(source, 0) + 1
            except OSError:
                link.send_errors += 1

    def control(self, path: str) -> None:
        with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as s:
            if os.path.exists(path):
                os.unlink(path)
            s.bind(path)
            while True:
                data, reply_to = s.recvfrom(65535)
                answer: dict[str, Any]
                try:
                    request = json.loads(data)
                    ports = self.ports if request.get("port", "*") == "*" else [request["port"]]
                    for port in ports:
                        link = self.links[port]
                        for key in ("delay_ms", "jitter_ms", "loss", "cut"):
                            if key in request:
                                setattr(link, key, type(getattr(link, key))(request[key]))
                    with self.lock:
                        for port, sock in self.sockets.items():
                            self.links[port].missed += struct.unpack(
                                "II", sock.getsockopt(SOL_PACKET, PACKET_STATISTICS, 8))[1]
                        answer = {p: asdict(link) for p, link in self.links.items()}
                except (ValueError, KeyError, TypeError) as exc:
                    answer = {"error": str(exc)}
                if reply_to:
                    s.sendto(json.dumps(answer).encode(), reply_to)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("ports", nargs="+")
    parser.add_argument("--control", required=True)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    hub = Hub(args.ports, args.seed)
    threading.Thread(target=hub.send, daemon=True).start()
    threading.Thread(target=hub.control, args=(args.control,), daemon=True).start()
    print("netshaper ready", flush=True)
    hub.receive()


if __name__ == "__main__":
    main()
