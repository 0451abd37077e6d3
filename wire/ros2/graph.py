"""The ROS 2 graph of a domain as rmw_zenoh's liveliness tokens tell it: who is there (nodes), what they publish,
subscribe, serve and call, with types, hashes and QoS. What ``ros2 node list`` and ``ros2 topic list -t`` read.

Zenoh calls back on its own threads; the graph is a dict behind a lock, read by copying.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any

import zenoh

from wire.ros2.errors import Ros2WireError
from wire.ros2.liveliness import Entity, EntityKind, NodeInfo, parse_token, subscription_keyexpr

log = logging.getLogger(__name__)
INITIAL_QUERY_TIMEOUT_S = 2.0


class Ros2Graph:
    """Follows every token of one domain from the moment it opens (the ones already there included).

    ``on_change`` is called (on a Zenoh thread, keep it short) after an entity came or went; ``version`` counts
    those changes, so a reader can tell whether the graph moved since it last looked."""

    def __init__(self, session: zenoh.Session, domain_id: int = 0,
                 on_change: Callable[[], None] | None = None) -> None:
        self.domain_id = domain_id
        self.version = 0
        self._on_change = on_change
        self._bad: set[str] = set()  # tokens that did not parse: counted once each, the first logged
        self._lock = threading.Lock()
        self._entities: dict[str, Entity] = {}
        self._subscriber: Any = session.liveliness().declare_subscriber(
            subscription_keyexpr(domain_id), self._on_token, history=True)
        # as rmw_zenoh does at start: ask for the tokens already there and wait for the answer, so the graph is
        # complete when the constructor returns (the subscriber's history arrives in the background)
        for reply in session.liveliness().get(subscription_keyexpr(domain_id), timeout=INITIAL_QUERY_TIMEOUT_S):
            if reply.ok is not None:
                self._on_token(reply.ok)

    def _on_token(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        if sample.kind == zenoh.SampleKind.DELETE:
            with self._lock:
                changed = self._entities.pop(key, None) is not None
            self._changed(changed)
            return
        try:
            entity = parse_token(key)
        except Ros2WireError as exc:
            with self._lock:
                first = not self._bad
                self._bad.add(key)
            if first:
                log.warning("ignoring a liveliness token that is not rmw_zenoh's (further ones only counted): %s",
                            exc)
            return
        with self._lock:
            changed = key not in self._entities
            self._entities[key] = entity
        self._changed(changed)

    def _changed(self, changed: bool) -> None:
        if not changed:
            return
        with self._lock:
            self.version += 1
        if self._on_change is not None:
            try:
                self._on_change()
            except Exception:  # a listener's failure must not stop the graph
                log.exception("graph listener failed")

    @property
    def bad_tokens(self) -> int:
        """How many different tokens of the domain did not parse (a stranger's process, another rmw version)."""
        with self._lock:
            return len(self._bad)

    def entities(self, kind: EntityKind | None = None) -> list[Entity]:
        with self._lock:
            found = list(self._entities.values())
        return [entity for entity in found if kind is None or entity.kind is kind]

    def nodes(self) -> list[NodeInfo]:
        """Every node, as ``ros2 node list`` shows them (fully_qualified_name)."""
        return sorted({entity.node for entity in self.entities(EntityKind.NODE)},
                      key=lambda node: node.fully_qualified_name)

    def endpoints_of(self, node: NodeInfo, kind: EntityKind) -> list[Entity]:
        """The node's publishers (or subscriptions, servers, clients), by topic name."""
        return sorted((e for e in self.entities(kind) if e.node == node), key=lambda e: e.topic.name if e.topic else "")

    def topics(self) -> dict[str, set[str]]:
        """Topic name -> its types (what ``ros2 topic list -t`` lists), from publishers and subscriptions."""
        found: dict[str, set[str]] = {}
        for entity in self.entities():
            if entity.kind in (EntityKind.PUBLISHER, EntityKind.SUBSCRIPTION) and entity.topic is not None:
                found.setdefault(entity.topic.name, set()).add(entity.topic.ros_type)
        return found

    def close(self) -> None:
        self._subscriber.undeclare()
