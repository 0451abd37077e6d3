"""The node graph of the robots on the bus: which node publishes, subscribes and serves what (the thesis' rqt_graph).

Nodes announce each entry as a Zenoh liveliness token (robot_nodes/runtime/graph.py, keys in wire.keys); Zenoh
withdraws a token when its node, process or link goes, so the graph here is right after a crash too. One liveliness
subscriber (with the tokens already present) keeps the set; the dashboard reads it at ``GET /api/graph`` and the
Foxglove endpoint serves it as the ConnectionGraph capability. Lab only: in match mode the server opens no Zenoh
session, so there is no graph.
"""

from __future__ import annotations

import contextlib
import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass, field

import zenoh

from server.zenoh_link import ZenohLink
from wire import keys

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True, order=True)
class GraphEntry:
    """One token: ``node`` of ``robot`` publishes (pub), subscribes (sub: its robot's; suball: every robot's) or
    serves (srv, action) ``name``."""

    robot: str
    node: str
    role: str
    name: str


@dataclass(slots=True)
class NodeEntries:
    """One node and its topics, services and actions, as the graph has them now."""

    robot: str
    node: str
    publishes: list[str] = field(default_factory=list)  # topics of its robot
    subscribes: list[str] = field(default_factory=list)  # topics of its robot
    subscribes_every_robot: list[str] = field(default_factory=list)  # the topic of every robot
    services: list[str] = field(default_factory=list)
    actions: list[str] = field(default_factory=list)


_FIELDS = {"pub": "publishes", "sub": "subscribes", "suball": "subscribes_every_robot", "srv": "services",
           "action": "actions"}


class NodeGraph:
    """The set of graph entries on the bus, kept from Zenoh's liveliness samples (Zenoh threads)."""

    def __init__(self, link: ZenohLink) -> None:
        self.link = link
        self.entries: set[GraphEntry] = set()
        self.version = 0  # counts changes; listeners compare it instead of the sets
        self.bad_keys = 0
        self._lock = threading.Lock()
        self._subscriber: zenoh.Subscriber[None] | None = None
        self._listeners: list[Callable[[], None]] = []

    def start(self) -> None:
        """Blocking (opens the server's Zenoh session): call from a worker thread. MatchModeError in match mode."""
        session = self.link.session()
        self._subscriber = session.liveliness().declare_subscriber(keys.GRAPH_ALL, self._on_sample, history=True)

    def stop(self) -> None:
        subscriber, self._subscriber = self._subscriber, None
        if subscriber is not None:
            with contextlib.suppress(Exception):  # the session closed first
                subscriber.undeclare()

    def on_change(self, listener: Callable[[], None]) -> None:
        """Called (on a Zenoh thread) after each change; keep it short."""
        self._listeners.append(listener)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        try:
            entry = GraphEntry(*keys.split_graph_key(str(sample.key_expr)))
        except ValueError:  # not a pitchside node's token, or a name that breaks the rules
            self.bad_keys += 1
            return
        with self._lock:
            if sample.kind == zenoh.SampleKind.DELETE:
                changed = entry in self.entries
                self.entries.discard(entry)
            else:
                changed = entry not in self.entries
                self.entries.add(entry)
            if changed:
                self.version += 1
        if changed:
            for listener in self._listeners:
                try:
                    listener()
                except Exception:  # a listener's failure must not stop the graph
                    log.exception("node graph listener failed")

    def snapshot(self) -> list[GraphEntry]:
        with self._lock:
            return sorted(self.entries)

    def nodes(self) -> list[NodeEntries]:
        """Every node with its entries, by robot and node name."""
        out: dict[tuple[str, str], NodeEntries] = {}
        for entry in self.snapshot():
            node = out.setdefault((entry.robot, entry.node), NodeEntries(entry.robot, entry.node))
            getattr(node, _FIELDS[entry.role]).append(entry.name)
        return list(out.values())

    def robots(self) -> list[str]:
        return sorted({e.robot for e in self.snapshot()})


@dataclass(slots=True)
class TopicLinks:
    """Who publishes and who subscribes one robot's topic (node ids ``/<robot>/<node>``)."""

    publishers: set[str] = field(default_factory=set)
    subscribers: set[str] = field(default_factory=set)


def node_id(robot: str, node: str) -> str:
    return f"/{robot}/{node}"


def topic_links(entries: list[GraphEntry]) -> dict[str, TopicLinks]:
    """``/<robot>/<topic>`` -> its publishers and subscribers. A subscription to every robot's topic counts for each
    robot of the graph (a robot joins the graph with its nodes)."""
    robots = sorted({e.robot for e in entries})
    links: dict[str, TopicLinks] = {}
    for entry in entries:
        who = node_id(entry.robot, entry.node)
        if entry.role == "pub":
            links.setdefault(f"/{entry.robot}/{entry.name}", TopicLinks()).publishers.add(who)
        elif entry.role == "sub":
            links.setdefault(f"/{entry.robot}/{entry.name}", TopicLinks()).subscribers.add(who)
        elif entry.role == "suball":
            for robot in robots:
                links.setdefault(f"/{robot}/{entry.name}", TopicLinks()).subscribers.add(who)
    return links


def service_providers(entries: list[GraphEntry]) -> dict[str, set[str]]:
    """``/<robot>/<service or action>`` -> the nodes serving it."""
    out: dict[str, set[str]] = {}
    for entry in entries:
        if entry.role in ("srv", "action"):
            out.setdefault(f"/{entry.robot}/{entry.name}", set()).add(node_id(entry.robot, entry.node))
    return out
