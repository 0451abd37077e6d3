"""/api/graph: the ROS 2 graph of the bus (server.node_graph, from rmw_zenoh's liveliness tokens): each node with
what it publishes, subscribes, serves and calls, and each topic with its publishers and subscribers, as ``ros2 node
info`` and ``ros2 topic info -v`` tell them. Reading only; in match mode (no Zenoh session) and with the live
source off there is no graph, and the answer says why."""

from __future__ import annotations

from fastapi import APIRouter, Depends
from pydantic import BaseModel

from server.deps import get_state
from server.node_graph import service_providers, topic_links
from server.state import ServerState
from server.zenoh_link import MATCH_MODE_REASON

router = APIRouter(prefix="/api", tags=["graph"])
NO_LIVE_SOURCE = "the live Zenoh source is off (--no-live): the server does not watch the bus"


class GraphNode(BaseModel):
    id: str  # the fully qualified node name (/robot1/hcm), as ros2 node list and Foxglove's topic graph name it
    namespace: str  # /robot1 (a pitchside node's robot), / for the root namespace
    node: str  # hcm
    publishes: list[str]  # fully qualified topic names (/robot1/joint_states, /rosout)
    subscribes: list[str]
    services: list[str]  # services it serves (actions apart)
    actions: list[str]  # actions it serves (/robot1/animation)
    clients: list[str]  # services it calls


class GraphTopic(BaseModel):
    topic: str  # /robot1/joint_states, /rosout
    publishers: list[str]  # node ids
    subscribers: list[str]


class GraphService(BaseModel):
    service: str  # a service or action: /robot1/manual_penalize, /robot1/animation
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
    nodes = [GraphNode(id=n.id, namespace=n.namespace, node=n.node, publishes=n.publishes, subscribes=n.subscribes,
                       services=n.services, actions=n.actions, clients=n.clients) for n in graph.nodes()]
    topics = [GraphTopic(topic=topic, publishers=sorted(links.publishers), subscribers=sorted(links.subscribers))
              for topic, links in sorted(topic_links(entries).items())]
    services = [GraphService(service=name, providers=sorted(providers))
                for name, providers in sorted(service_providers(entries).items())]
    return NodeGraphView(available=True, reason="", nodes=nodes, topics=topics, services=services)
