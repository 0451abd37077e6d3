"""/api/graph: the node graph of the robots on the bus (server.node_graph): each node with what it publishes,
subscribes and serves, and each topic with its publishers and subscribers. Reading only; in match mode (no Zenoh
session) and with the live source off there is no graph, and the answer says why."""

from __future__ import annotations

from fastapi import APIRouter, Depends
from pydantic import BaseModel

from server.deps import get_state
from server.node_graph import node_id, service_providers, topic_links
from server.state import ServerState
from server.zenoh_link import MATCH_MODE_REASON

router = APIRouter(prefix="/api", tags=["graph"])
NO_LIVE_SOURCE = "the live Zenoh source is off (--no-live): the server does not watch the bus"


class GraphNode(BaseModel):
    id: str  # /<robot>/<node>, as Foxglove's topic graph names it
    robot: str
    node: str
    publishes: list[str]  # topics of its robot
    subscribes: list[str]  # topics of its robot
    subscribes_every_robot: list[str]  # this topic of every robot
    services: list[str]
    actions: list[str]


class GraphTopic(BaseModel):
    topic: str  # /<robot>/<topic>
    publishers: list[str]  # node ids
    subscribers: list[str]


class GraphService(BaseModel):
    service: str  # /<robot>/<service or action>
    providers: list[str]


class NodeGraphView(BaseModel):
    available: bool
    reason: str  # why not available ("" when it is)
    nodes: list[GraphNode]
    topics: list[GraphTopic]
    services: list[GraphService]


@router.get("/graph", response_model=NodeGraphView)
def node_graph(state: ServerState = Depends(get_state)) -> NodeGraphView:
    graph = state.graph
    if graph is None:
        reason = MATCH_MODE_REASON if state.config.match_mode else NO_LIVE_SOURCE
        return NodeGraphView(available=False, reason=reason, nodes=[], topics=[], services=[])
    entries = graph.snapshot()
    nodes = [GraphNode(id=node_id(n.robot, n.node), robot=n.robot, node=n.node, publishes=n.publishes,
                       subscribes=n.subscribes, subscribes_every_robot=n.subscribes_every_robot, services=n.services,
                       actions=n.actions) for n in graph.nodes()]
    topics = [GraphTopic(topic=topic, publishers=sorted(links.publishers), subscribers=sorted(links.subscribers))
              for topic, links in sorted(topic_links(entries).items())]
    services = [GraphService(service=name, providers=sorted(providers))
                for name, providers in sorted(service_providers(entries).items())]
    return NodeGraphView(available=True, reason="", nodes=nodes, topics=topics, services=services)
