"""The SDK's two WebSocket servers behind the guard, and what each offers.

foxglove-sdk 0.30 offers its capabilities to every client of a server alike, and cannot tell which client showed a
token. So there are two servers on one context (the same channels): the guard (server.foxglove.guard) passes a
connection that showed the dashboard's token to ``control``, any other to ``view``, as the dashboard asks its
credential for control and not for watching:

=====================  ===============================  =====================================================
capability             view (no token)                  control (the token)
=====================  ===============================  =====================================================
channels, assets       yes                              yes
ConnectionGraph        lab, with the live source on     lab, with the live source on
Parameters             no                               lab
Services               no                               lab: each live robot's manual_penalize, play_animation
ClientPublish          no                               lab: ``/<robot>/cmd_vel``
Time                   while a log is replayed          while a log is replayed
PlaybackControl        no                               while a log is replayed (in match mode too)
=====================  ===============================  =====================================================

In match mode the server sends nothing to any robot: no capability that would is offered to anyone, and the
servers have no Zenoh session to send with. The log's time range is part of the servers' handshake, so the
servers are started again (clients reconnect, Foxglove does so by itself) when a replay opens or closes.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
from typing import Any

import foxglove
from foxglove.websocket import Capability

from server.foxglove.guard import SdkPorts
from server.loopback_ports import LOOPBACK, internal_port

SERVER_NAME = "pitchside"
# Per client: messages the SDK queues before it drops the oldest. At 11 robots' rates that is a fraction of a
# second, and with images a few MB at most, so a client that never reads costs bounded memory.
CLIENT_BACKLOG = 1024
ENCODINGS = ["cdr", "json"]  # what clients may send (cmd_vel, service requests): ROS 2 CDR, or JSON as Foxglove's
# Teleop panel sends it
BIND_ATTEMPTS = 5  # another program (a second dashboard, a test beside) may bind the port we found free first


class ServerStartError(RuntimeError):
    """An SDK server could not start (no port could be bound); the text says why."""


@dataclass(frozen=True, slots=True)
class Offer:
    """What the endpoint offers now: lab or match, the node graph, a replayed log's time range."""

    lab: bool
    graph: bool
    replay: tuple[int, int] | None = None  # (start_ns, end_ns) of the log being replayed

    def capabilities(self, door: str) -> list[Capability]:
        """The capabilities of the ``view`` or the ``control`` server."""
        out = []
        if self.graph and self.lab:
            out.append(Capability.ConnectionGraph)
        if door == "control" and self.lab:
            out += [Capability.Parameters, Capability.Services, Capability.ClientPublish]
        if self.replay is not None:
            out.append(Capability.Time)  # control gets PlaybackControl with the time range
        return out


class SdkServers:
    """The running ``view`` and ``control`` servers (replaced together when the offer changes)."""

    def __init__(self, context: foxglove.Context, listeners: dict[str, Any], assets: Any) -> None:
        self.context = context
        self.listeners = listeners  # door -> foxglove.websocket.ServerListener
        self.assets = assets
        self.servers: dict[str, Any] = {}  # door -> foxglove.websocket.WebSocketServer
        self.offer: Offer | None = None

    @property
    def ports(self) -> SdkPorts:
        return SdkPorts(view=int(self.servers["view"].port), control=int(self.servers["control"].port))

    def start(self, offer: Offer) -> None:
        """Blocking (binds ports): call from a worker thread."""
        self.stop()
        self.offer = offer
        for door in ("view", "control"):
            taken: list[int] = []  # ports another program bound between our look and the SDK's bind
            while True:
                # the SDK binds with SO_REUSEADDR: a port its last server left connections on is free for it
                port = internal_port(0, f"Foxglove endpoint ({door})", avoid=tuple(taken), reuse_address=True)
                try:
                    self.servers[door] = foxglove.start_server(
                        name=SERVER_NAME, host=LOOPBACK, port=port, context=self.context,
                        capabilities=offer.capabilities(door), server_listener=self.listeners[door],
                        supported_encodings=ENCODINGS if door == "control" and offer.lab else None,
                        asset_handler=self.assets, message_backlog_size=CLIENT_BACKLOG,
                        playback_time_range=offer.replay if door == "control" else None)
                    break
                except RuntimeError as exc:  # the SDK says FoxgloveError: Failed to bind port ...
                    taken.append(port)
                    if len(taken) < BIND_ATTEMPTS:
                        continue
                    self.stop()
                    raise ServerStartError(f"Foxglove endpoint not started on {LOOPBACK} (ports {taken}): "
                                           f"{exc}") from None

    def has(self, door: str, capability: Capability) -> bool:
        return self.offer is not None and door in self.servers and capability in self.offer.capabilities(door)

    def stop(self) -> None:
        for server in self.servers.values():
            with contextlib.suppress(Exception):
                server.stop()
        self.servers.clear()
