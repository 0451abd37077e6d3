"""GameControllerListener: the newest GameController packet for something that is not a robot (the simulation's
referee when a real GameController runs the match). It binds with address reuse beside the robots' nodes and
needs the GameController to broadcast, as it does on a field."""

from __future__ import annotations

import logging
import threading

from robot_nodes.runtime.udp import UdpPort
from wire.gamecontroller.packets import (
    DATA_PORT,
    GameControlData,
    GameControllerPacketError,
    parse_state_packet,
)

log = logging.getLogger("pitchside.gc_listener")


class GameControllerListener:
    """Keeps the newest packet of the teams asked for (any, without teams); ``latest()`` from any thread."""

    def __init__(self, address: str = "0.0.0.0", port: int = DATA_PORT, teams: tuple[int, ...] = ()) -> None:
        self.teams = set(teams)
        self.packets = 0
        self.bad_packets = 0
        self.foreign_packets = 0
        self._lock = threading.Lock()
        self._latest: GameControlData | None = None
        self._udp = UdpPort(address, port, self._on_datagram, recv_size=2048, name="gc-listener", reuse_address=True)

    @property
    def port(self) -> int:
        return self._udp.port

    def latest(self) -> GameControlData | None:
        with self._lock:
            return self._latest

    def close(self) -> None:
        self._udp.close()

    def _on_datagram(self, data: bytes, addr: tuple[str, int]) -> None:
        try:
            packet = parse_state_packet(data)
        except GameControllerPacketError as exc:
            self.bad_packets += 1
            log.debug("bad GameController packet from %s: %s", addr[0], exc)
            return
        if self.teams and not self.teams <= {t.team_number for t in packet.teams}:
            self.foreign_packets += 1  # another field's game
            return
        self.packets += 1
        with self._lock:
            self._latest = packet
