"""The node graph of the bus: which node publishes, subscribes and serves what (the thesis' rqt_graph).

Read from rmw_zenoh's liveliness tokens (``@ros2_lv/<domain>/...``, wire.ros2.graph.Ros2Graph), the same tokens
``ros2 node list`` and ``ros2 topic info -v`` read, so pitchside's nodes and any ROS 2 node of the domain show
alike. Zenoh withdraws a token when its node, process or link goes, so the graph here is right after a crash too.
The dashboard reads it at ``GET /api/graph`` and the Foxglove endpoint serves it as the ConnectionGraph capability.
Lab only: in match mode the server opens no Zenoh session, so there is no graph.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Callable
from dataclasses import dataclass, field

from server.zenoh_link import ZenohLink
from wire import keys
from wire.ros2.graph import Ros2Graph
from wire.ros2.liveliness import Entity, EntityKind

log = logging.getLogger(__name__)

# rmw_zenoh serves an action as three services and two topics under <action>/_action/ (ROS 2's action protocol);
# the graph lists the action once, by its send_goal service
ACTION_INFIX = "/_action/"
ACTION_SEND_GOAL = ACTION_INFIX + "send_goal"


@dataclass(frozen=True, slots=True, order=True)
class GraphEntry:
    """One entity: the node ``node`` (fully qualified: ``/robot1/hcm``) publishes (pub), subscribes (sub), serves
    (srv, action) or calls (client) ``name`` (fully qualified: ``/robot1/joint_states``, ``/rosout``)."""

    node: str
    role: str
    name: str


@dataclass(slots=True)
class NodeEntries:
    """One node and its topics, services and actions, as the graph has them now (fully qualified names)."""

    id: str  # /robot1/hcm
    namespace: str  # /robot1 (the robot of a pitchside node), / for a node in the root namespace
    node: str  # hcm
    publishes: list[str] = field(default_factory=list)
    subscribes: list[str] = field(default_factory=list)
    services: list[str] = field(default_factory=list)
    actions: list[str] = field(default_factory=list)
    clients: list[str] = field(default_factory=list)


_FIELDS = {"pub": "publishes", "sub": "subscribes", "srv": "services", "action": "actions", "client": "clients"}
_ROLES = {EntityKind.PUBLISHER: "pub", EntityKind.SUBSCRIPTION: "sub", EntityKind.SERVICE: "srv",
          EntityKind.CLIENT: "client"}


def entry_of(entity: Entity) -> GraphEntry | None:
    """The graph entry of a token's entity; None for a node (its entries carry it) and for an action's parts
    other than its send_goal service (one entry per action)."""
    if entity.kind is EntityKind.NODE or entity.topic is None:
        return None
    node, name, role = entity.node.fully_qualified_name, entity.topic.name, _ROLES[entity.kind]
    if ACTION_INFIX in name:
        if entity.kind is not EntityKind.SERVICE or not name.endswith(ACTION_SEND_GOAL):
            return None
        return GraphEntry(node, "action", name[:-len(ACTION_SEND_GOAL)])
    return GraphEntry(node, role, name)


class NodeGraph:
    """The graph of the server's domain (ROS_DOMAIN_ID), kept from Zenoh's liveliness samples (Zenoh threads)."""

    def __init__(self, link: ZenohLink) -> None:
        self.link = link
        self._graph: Ros2Graph | None = None
        self._listeners: list[Callable[[], None]] = []

    def start(self) -> None:
        """Blocking (opens the server's Zenoh session, asks for the tokens already there): call from a worker
        thread. MatchModeError in match mode."""
        self._graph = Ros2Graph(self.link.session(), keys.domain_id(), on_change=self._changed)

    def stop(self) -> None:
        graph, self._graph = self._graph, None
        if graph is not None:
            with contextlib.suppress(Exception):  # the session closed first
                graph.close()

    @property
    def version(self) -> int:
        """Counts changes; listeners compare it instead of the sets."""
        return self._graph.version if self._graph is not None else 0

    @property
    def bad_keys(self) -> int:
        """Tokens of the domain that are not rmw_zenoh's (counted; the first one logged)."""
        return self._graph.bad_tokens if self._graph is not None else 0

    def on_change(self, listener: Callable[[], None]) -> None:
        """Called (on a Zenoh thread) after each change; keep it short."""
        self._listeners.append(listener)

    def _changed(self) -> None:
        for listener in self._listeners:
            try:
                listener()
            except Exception:  # a listener's failure must not stop the graph
                log.exception("node graph listener failed")

    def snapshot(self) -> list[GraphEntry]:
        graph = self._graph
        if graph is None:
            return []
        return sorted({entry for entity in graph.entities() if (entry := entry_of(entity)) is not None})

    def nodes(self) -> list[NodeEntries]:
        """Every node (those without entries too), by fully qualified name, as ``ros2 node info`` shows them."""
        graph = self._graph
        if graph is None:
            return []
        out = {info.fully_qualified_name: NodeEntries(info.fully_qualified_name, info.namespace, info.name)
               for info in graph.nodes()}
        for entry in self.snapshot():
            node = out.get(entry.node)
            if node is not None:  # an entity whose node token has not come yet shows with its node
                getattr(node, _FIELDS[entry.role]).append(entry.name)
        return [out[name] for name in sorted(out)]


@dataclass(slots=True)
class TopicLinks:
    """Who publishes and who subscribes one topic (node ids: fully qualified node names)."""

    publishers: set[str] = field(default_factory=set)
    subscribers: set[str] = field(default_factory=set)


def topic_links(entries: list[GraphEntry]) -> dict[str, TopicLinks]:
    """Topic name (``/robot1/joint_states``, ``/rosout``) -> its publishers and subscribers."""
    links: dict[str, TopicLinks] = {}
    for entry in entries:
        if entry.role == "pub":
            links.setdefault(entry.name, TopicLinks()).publishers.add(entry.node)
        elif entry.role == "sub":
            links.setdefault(entry.name, TopicLinks()).subscribers.add(entry.node)
    return links


def service_providers(entries: list[GraphEntry]) -> dict[str, set[str]]:
    """Service or action name (``/robot1/manual_penalize``, ``/robot1/animation``) -> the nodes serving it."""
    out: dict[str, set[str]] = {}
    for entry in entries:
        if entry.role in ("srv", "action"):
            out.setdefault(entry.name, set()).add(entry.node)
    return out
