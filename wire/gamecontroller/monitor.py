"""A monitor of the HSL GameController (what a team-communication monitor or event recorder is): it registers
with the GameController and gets the true game state and every robot's status packet.

From the GameController's README (2026): a monitor sends ``RGTr`` + version byte 0 to UDP 3636; the GameController
then sends it control packets with the true game state (no delayed state after a whistle) with the magic ``RGTD``,
unicast to its port 3838 at 2 Hz, and forwards each robot's status packet unicast to its port 3940, prefixed by the
sender's IPv4 address (4 bytes), unvalidated. It refuses monitor requests from hosts that have sent status packets
(robots), so a monitor never runs on a robot and never shares a host with one; a team may use it off the field
(a laptop beside the GameController, as the TeamCommunicationMonitor is used), never in the robots' network path.
"""

from __future__ import annotations

import contextlib
import ipaddress
import logging
import socket
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from wire.gamecontroller.game_data import GameControlData, GameControllerPacketError, StatusPacket
from wire.gamecontroller.hsl import parse_status_packet
from wire.gamecontroller.packets import STATE_HEADER, parse_state_packet

log = logging.getLogger("pitchside.gc_monitor")

MONITOR_REQUEST_PORT = 3636
MONITOR_DATA_PORT = 3838
MONITOR_FORWARD_PORT = 3940
MONITOR_REQUEST = b"RGTr\x00"
TRUE_DATA_HEADER = b"RGTD"
REQUEST_PERIOD_S = 5.0  # asked again now and then: a GameController started later, or restarted, hears it too


def parse_true_data(data: bytes | bytearray | memoryview) -> GameControlData:
    """An ``RGTD`` packet: a control packet of the true game state; GameControllerPacketError otherwise."""
    data = bytes(data)
    if data[:4] != TRUE_DATA_HEADER:
        raise GameControllerPacketError(f"wrong monitor data header {data[:4]!r}, expected {TRUE_DATA_HEADER!r}",
                                        "wrong_header" if len(data) >= 4 else "truncated")
    return parse_state_packet(STATE_HEADER + data[4:])


def parse_forwarded_status(data: bytes | bytearray | memoryview) -> tuple[str, StatusPacket]:
    """A forwarded status packet: (the robot's IPv4 address, its packet); GameControllerPacketError otherwise."""
    data = bytes(data)
    if len(data) < 4:
        raise GameControllerPacketError(f"forwarded status packet too short: {len(data)} bytes", "truncated")
    return str(ipaddress.IPv4Address(data[:4])), parse_status_packet(data[4:])


class _Listener:
    """A bound UDP socket and the thread that reads it (the monitor stands below the nodes' runtime)."""

    def __init__(self, host: str, port: int, handler: Callable[[bytes, tuple[str, int]], None], name: str) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # beside a team-communication monitor
        try:
            self.sock.bind((host, port))
        except OSError:
            self.sock.close()
            raise
        self._handler = handler
        self._closed = threading.Event()
        self._thread = threading.Thread(target=self._read, name=name, daemon=True)
        self._thread.start()

    @property
    def port(self) -> int:
        return int(self.sock.getsockname()[1])

    def sendto(self, data: bytes, address: tuple[str, int]) -> None:
        self.sock.sendto(data, address)

    def _read(self) -> None:
        while not self._closed.is_set():
            try:
                data, addr = self.sock.recvfrom(2048)
            except OSError:
                return
            if not self._closed.is_set() and data:
                self._handler(data, addr)

    def close(self) -> None:
        self._closed.set()
        with contextlib.suppress(OSError):  # wakes the reader
            self.sock.shutdown(socket.SHUT_RDWR)
        self._thread.join(2.0)
        self.sock.close()


@dataclass
class RobotSeen:
    """A robot's newest status packet as the GameController forwarded it."""

    address: str
    status: StatusPacket
    received: float  # monotonic


@dataclass
class MonitorCounts:
    true_packets: int = 0
    statuses: int = 0
    bad_packets: int = 0
    last_error: str = ""
    robots: dict[tuple[int, int], RobotSeen] = field(default_factory=dict)


class GameControllerMonitor:
    """Registers with the GameController at ``gc_host`` and keeps the newest true state and each robot's status
    (``latest()``, ``robots()``, from any thread). Off unless started; the dashboard's flag starts it."""

    def __init__(self, gc_host: str, request_port: int = MONITOR_REQUEST_PORT, listen_address: str = "0.0.0.0",
                 data_port: int = MONITOR_DATA_PORT, forward_port: int = MONITOR_FORWARD_PORT,
                 request_period_s: float = REQUEST_PERIOD_S) -> None:
        self.gc_host = gc_host
        self.request_port = request_port
        self.request_period_s = request_period_s
        self.counts = MonitorCounts()
        self.requests_sent = 0
        self._lock = threading.Lock()
        self._latest: GameControlData | None = None
        self._stop = threading.Event()
        self._data = _Listener(listen_address, data_port, self._on_true_data, "gc-monitor-data")
        try:
            self._forward = _Listener(listen_address, forward_port, self._on_forwarded, "gc-monitor-status")
        except OSError:
            self._data.close()
            raise
        self._thread = threading.Thread(target=self._request_loop, name="gc-monitor-request", daemon=True)

    @property
    def data_port(self) -> int:
        return self._data.port

    @property
    def forward_port(self) -> int:
        return self._forward.port

    def start(self) -> GameControllerMonitor:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(2.0)
        self._data.close()
        self._forward.close()

    def __enter__(self) -> GameControllerMonitor:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def latest(self) -> GameControlData | None:
        with self._lock:
            return self._latest

    def robots(self) -> dict[tuple[int, int], RobotSeen]:
        """(team, player) -> the robot's newest status packet."""
        with self._lock:
            return dict(self.counts.robots)

    def _request_loop(self) -> None:
        while not self._stop.is_set():
            try:
                self._data.sendto(MONITOR_REQUEST, (self.gc_host, self.request_port))
                self.requests_sent += 1
            except OSError as exc:  # no route yet: the next period tries again
                log.debug("cannot send the monitor request to %s:%d: %s", self.gc_host, self.request_port, exc)
            self._stop.wait(self.request_period_s)

    def _bad(self, what: str, exc: GameControllerPacketError) -> None:
        with self._lock:
            self.counts.bad_packets += 1
            self.counts.last_error = f"{what}: {exc}"
        log.debug("bad %s: %s", what, exc)

    def _on_true_data(self, data: bytes, addr: tuple[str, int]) -> None:
        try:
            packet = parse_true_data(data)
        except GameControllerPacketError as exc:
            self._bad(f"monitor data from {addr[0]}", exc)
            return
        with self._lock:
            self._latest = packet
            self.counts.true_packets += 1

    def _on_forwarded(self, data: bytes, addr: tuple[str, int]) -> None:
        try:
            robot, status = parse_forwarded_status(data)
        except GameControllerPacketError as exc:
            self._bad(f"forwarded status from {addr[0]}", exc)
            return
        with self._lock:
            self.counts.statuses += 1
            self.counts.robots[(status.team, status.player)] = RobotSeen(robot, status, time.monotonic())
