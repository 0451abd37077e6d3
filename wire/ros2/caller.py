"""pitchside's callers on the ROS 2 graph: one node per Zenoh session and domain (``/pitchside_caller_<zid>``) for
the dashboard's, the tools' and the tests' service calls, with one client per service, so each call goes out as
rmw_zenoh's clients send it (SC token, attachment with the client's GID) without a token per call.

Sessions close without telling us: a closed session's caller is forgotten the next time anyone asks.
"""

from __future__ import annotations

import threading

import zenoh

from wire.ros2.endpoints import Ros2Client, Ros2Node, Ros2Subscription, SampleCallback
from wire.ros2.graph import Ros2Graph
from wire.ros2.liveliness import Entity, EntityKind, NodeInfo
from wire.ros2.qos import QoS
from wire.ros2.robots import next_node_id

_lock = threading.Lock()
_callers: dict[tuple[str, int], tuple[zenoh.Session, Caller]] = {}


class Caller:
    """A session's ROS 2 node for calls in one domain."""

    def __init__(self, session: zenoh.Session, domain_id: int) -> None:
        self.session = session
        self.domain_id = domain_id
        zid = str(session.zid())
        self.node = Ros2Node(session, NodeInfo(domain_id, "/", f"pitchside_caller_{zid[:12]}"), next_node_id())
        self._clients: dict[tuple[str, str, str], Ros2Client] = {}
        self._graph: Ros2Graph | None = None
        self._lock = threading.Lock()

    def client(self, name: str, srv_type: str, type_hash: str) -> Ros2Client:
        """The node's client of one service (declared on first use, kept with the session)."""
        with self._lock:
            key = (name, srv_type, type_hash)
            if key not in self._clients:
                self._clients[key] = self.node.create_client(name, srv_type, type_hash)
            return self._clients[key]

    def subscribe(self, name: str, ros_type: str, type_hash: str, callback: SampleCallback,
                  qos: QoS | None = None) -> Ros2Subscription:
        """A subscription of this node (its caller closes it)."""
        return self.node.create_subscription(name, ros_type, type_hash, callback, qos)

    def servers(self) -> list[Entity]:
        """Every service server of the domain, from the domain's liveliness tokens (followed from the first ask on;
        a wildcard liveliness query through a router misses tokens, a subscription does not)."""
        with self._lock:
            if self._graph is None:
                self._graph = Ros2Graph(self.session, self.domain_id)
            graph = self._graph
        return graph.entities(EntityKind.SERVICE)


def caller(session: zenoh.Session, domain_id: int) -> Caller:
    """The caller node of this session in this domain."""
    key = (str(session.zid()), domain_id)
    with _lock:
        for other in [k for k, (s, _) in _callers.items() if s.is_closed()]:
            del _callers[other]
        if key not in _callers:
            _callers[key] = (session, Caller(session, domain_id))
        return _callers[key][1]
