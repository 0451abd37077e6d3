"""The robots on the ROS 2 side, as rmw_zenoh's liveliness tokens show them (not as their data does): a node in a
domain the team file names is that robot's; a node in a namespace (``/robot1/hcm``) of any other domain is the
namespace's robot. Each robot lists its nodes and the topics they publish, with the dashboard's verdict on each
(shown, on which panel topic, or why not: "definition missing", a hash that does not match).
"""

from __future__ import annotations

from typing import Any

import zenoh

from server.profiles.routes import RouteRefused, route
from server.profiles.team import Ros2Setup
from wire import keys
from wire.ros2.graph import Ros2Graph
from wire.ros2.liveliness import Entity, EntityKind, NodeInfo


class Ros2Robots:
    """One Ros2Graph per listened domain (each complete when the constructor returns)."""

    def __init__(self, session: zenoh.Session, setup: Ros2Setup) -> None:
        self.setup = setup
        self.graphs: dict[int, Ros2Graph] = {}
        try:
            for domain in setup.listened():
                self.graphs[domain] = Ros2Graph(session, domain)
        except Exception:
            self.close()
            raise

    def robot_of(self, node: NodeInfo) -> str | None:
        """The robot a node belongs to, or None (a root-namespace node of a namespace domain: a tool, a bridge)."""
        named = self.setup.team.get(node.domain_id)
        if named is not None:
            return named
        first = node.namespace.strip("/").split("/", 1)[0]
        return first if first and keys.is_valid_name(first) else None

    def _topic(self, publisher: Entity) -> dict[str, Any]:
        assert publisher.topic is not None
        shown: dict[str, Any] = {"name": publisher.topic.name, "type": publisher.topic.ros_type,
                                 "type_hash": publisher.topic.type_hash}
        try:
            found = route(publisher.topic.keyexpr, self.setup)
        except RouteRefused as exc:
            shown.update(status=exc.reason.value, panel=None)
        else:
            shown.update(status="shown", panel=found.topic)
        return shown

    def robots(self) -> list[dict[str, Any]]:
        """Every robot with its domain, nodes and published topics, by robot id."""
        found: dict[str, dict[str, Any]] = {}
        for domain, graph in self.graphs.items():
            for node in graph.nodes():
                robot = self.robot_of(node)
                if robot is None:
                    continue
                entry = found.setdefault(robot, {"robot": robot, "domain": domain, "nodes": [], "topics": {}})
                entry["nodes"].append(node.fully_qualified_name)
                for publisher in graph.endpoints_of(node, EntityKind.PUBLISHER):
                    if publisher.topic is not None:
                        entry["topics"].setdefault(publisher.topic.name, self._topic(publisher))
        return [{**entry, "nodes": sorted(set(entry["nodes"])), "topics": sorted(entry["topics"].values(),
                                                                               key=lambda t: t["name"])}
                for _, entry in sorted(found.items())]

    @property
    def bad_tokens(self) -> int:
        return sum(graph.bad_tokens for graph in self.graphs.values())

    def close(self) -> None:
        for graph in self.graphs.values():
            graph.close()
        self.graphs = {}
