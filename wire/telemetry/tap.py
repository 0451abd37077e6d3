"""TelemetryTap: the robots' telemetry port, its datagrams handed on unchanged to the dashboard and the recorder.

A unicast UDP datagram reaches one socket only, so the dashboard and the recorder, two processes that each must live
when the other dies, cannot both listen on the robots' port. The tap runs in the supervisor's process (the one that
outlives both), reads the port and sends each datagram on to every destination on loopback: no decoding, no
acknowledgement, nothing sent back to a robot. A destination that is down (restarting) just misses those datagrams.
"""

from __future__ import annotations

import logging
import random
import select
import socket
import threading

log = logging.getLogger(__name__)

MAX_DATAGRAM = 65535
RECEIVE_BUFFER_BYTES = 4 << 20  # a burst of camera fragments while the tap's thread waits for the CPU


class TelemetryTap:
    """Listens on ``host:port`` and copies every datagram to ``destinations`` ((host, port) pairs on loopback)."""

    def __init__(self, host: str, port: int, destinations: list[tuple[str, int]], drop_fraction: float = 0.0) -> None:
        """drop_fraction: that share of datagrams dropped at random (a bench's stand-in for a venue's Wi-Fi)."""
        self.destinations = list(destinations)
        self.drop_fraction = drop_fraction
        self.dropped = 0
        self._random = random.Random()
        self.datagrams = 0
        self.send_errors = 0  # a destination down: counted, never fatal
        self._in = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._in.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RECEIVE_BUFFER_BYTES)
        self._in.bind((host, port))
        self.port = int(self._in.getsockname()[1])
        self._out = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._out.bind(("127.0.0.1", 0))  # it only sends, to loopback: bound there, never reachable from outside
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="telemetry-tap", daemon=True)

    def start(self) -> TelemetryTap:
        self._thread.start()
        return self

    def _run(self) -> None:
        while not self._stop.is_set():
            ready, _, _ = select.select([self._in], [], [], 0.2)
            if not ready:
                continue
            try:
                data = self._in.recv(MAX_DATAGRAM)
            except OSError:
                continue
            self.datagrams += 1
            if self.drop_fraction and self._random.random() < self.drop_fraction:
                self.dropped += 1
                continue
            for destination in self.destinations:
                try:
                    self._out.sendto(data, destination)
                except OSError:  # ECONNREFUSED from the last send to a process that is restarting
                    self.send_errors += 1

    def close(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(2.0)
        self._in.close()
        self._out.close()

    def __enter__(self) -> TelemetryTap:
        return self.start()

    def __exit__(self, *_exc: object) -> None:
        self.close()
