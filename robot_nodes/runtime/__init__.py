"""The small runtime every robot node uses: its loop, timers, publishers and subscriptions, parameters, and the
service and action servers; what nodes share with the server (keys, bus, protocols, clients) is in ``wire``."""

from robot_nodes.runtime.action_server import ActionServer, ServerGoal
from robot_nodes.runtime.node import LatestMessage, Node, Publisher, Subscription, header, run, stamp_now
from robot_nodes.runtime.parameters import ParameterStore, param
from robot_nodes.runtime.service_server import ServiceServer
from wire.actions import ActionClient, ActionError, ClientGoal, GoalStatus
from wire.bus import BusConfig, open_router, open_session
from wire.parameters import ParameterClient, ParameterError
from wire.services import ServiceError, call_service

__all__ = [
    "ActionClient",
    "ActionError",
    "ActionServer",
    "BusConfig",
    "ClientGoal",
    "GoalStatus",
    "LatestMessage",
    "Node",
    "ParameterClient",
    "ParameterError",
    "ParameterStore",
    "Publisher",
    "ServerGoal",
    "ServiceError",
    "ServiceServer",
    "Subscription",
    "call_service",
    "header",
    "open_router",
    "open_session",
    "param",
    "run",
    "stamp_now",
]
