"""A node's services and actions on the ROS 2 graph: the service-server (SS) tokens rmw_zenoh declares for them,
so ``ros2 service list``, ``ros2 action list`` and the dashboard's graph (server/node_graph.py) see who serves what.

The node's own token (NN) and those of its publishers and subscriptions (MP, MS) are declared by the node and by
each Publisher and Subscription (node.py). A token lives as long as the node holds it, and Zenoh drops it when the
node's session or process ends however it ends (a crash, SIGKILL, a cut link), so the graph never shows a dead
node. A service server or action server that declares its own tokens (rmw_zenoh's service and action protocol)
makes this module's entries redundant: it only fills in for servers that do not.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Callable
from typing import Any

import zenoh

import schemas
from schemas.codec import type_hash
from wire.ros2.keys import TopicKey
from wire.ros2.liveliness import Entity, EntityKind, NodeInfo
from wire.ros2.qos import QoS

log = logging.getLogger(__name__)


class ServedTokens:
    """The SS tokens of one node's services; each declared once, however often the node asks."""

    def __init__(self, session: zenoh.Session, zid: str, node: NodeInfo, node_id: int,
                 next_entity_id: Callable[[], int]) -> None:
        self.session = session
        self.zid = zid
        self.node = node
        self.node_id = node_id
        self._next_entity_id = next_entity_id
        self.tokens: dict[str, Any] = {}  # token key -> zenoh.LivelinessToken

    def serves(self, service: str) -> None:
        """A service of the table (``manual_penalize``) in the node's namespace."""
        srv_type = schemas.SERVICES[service].type
        self._declare(f"{self.node.namespace.rstrip('/')}/{service}", srv_type)

    def _declare(self, name: str, ros_type: str) -> None:
        if name in self.tokens:
            return
        try:
            topic = TopicKey(self.node.domain_id, name, ros_type, type_hash(ros_type))
            entity = Entity(self.zid, self.node_id, self._next_entity_id(), EntityKind.SERVICE, self.node, topic,
                            QoS(depth=10))
            self.tokens[name] = self.session.liveliness().declare_token(entity.token)
        except Exception as exc:  # a bus whose access control refuses tokens, a name ROS 2 cannot carry: unlisted
            log.debug("%s not on the ROS 2 graph: %s", name, exc)

    def close(self) -> None:
        for token in self.tokens.values():
            with contextlib.suppress(Exception):  # gone with the session already
                token.undeclare()
        self.tokens.clear()
