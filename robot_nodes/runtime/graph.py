"""A node's place in the node graph: what it publishes, subscribes and serves, as Zenoh liveliness tokens.

A token lives as long as the node holds it, and Zenoh drops it when the node's session or process ends however it
ends (a crash, SIGKILL, a cut link), so the graph the dashboard reads (server/node_graph.py, Foxglove's topic graph)
never shows a dead node. Keys: ``wire.keys.graph_key``. Nodes composed in one process share one Zenoh session; each
still declares its own tokens under its own name, so closing one of them takes away its entries only.
"""

from __future__ import annotations

import contextlib
import logging
from typing import Any

import zenoh

from wire import keys

log = logging.getLogger(__name__)


class GraphAnnouncer:
    """The liveliness tokens of one node; each entry is declared once, however often the node asks."""

    def __init__(self, session: zenoh.Session, robot: str, node: str) -> None:
        self.session = session
        self.robot = robot
        self.node = node
        self.tokens: dict[str, Any] = {}  # key -> zenoh.LivelinessToken

    def publishes(self, topic: str) -> None:
        self._announce("pub", topic)

    def subscribes(self, topic: str, robot: str) -> None:
        """robot: the robot whose topic it is (``*``: every robot's)."""
        if robot == keys.ANY_ROBOT:
            self._announce("suball", topic)
        elif robot == self.robot:
            self._announce("sub", topic)
        # another single robot's topic: no node does that; the graph has no role for it yet

    def serves(self, service: str) -> None:
        self._announce("srv", service)

    def serves_action(self, action: str) -> None:
        self._announce("action", action)

    def _announce(self, role: str, name: str) -> None:
        try:
            key = keys.graph_key(self.robot, self.node, role, name)
        except ValueError as exc:  # a name the graph cannot carry: the node works without that entry
            log.debug("%s not in the node graph: %s", name, exc)
            return
        if key in self.tokens:
            return
        try:
            self.tokens[key] = self.session.liveliness().declare_token(key)
        except Exception as exc:  # a bus whose access control refuses tokens: the node works, unlisted
            log.debug("%s not in the node graph: %s", key, exc)

    def close(self) -> None:
        for token in self.tokens.values():
            with contextlib.suppress(Exception):  # gone with the session already
                token.undeclare()
        self.tokens.clear()
