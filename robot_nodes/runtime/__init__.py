"""The small runtime every robot node uses: Zenoh session, topics, timers, parameters, services, actions."""

from robot_nodes.runtime.actions import (
    ActionClient,
    ActionError,
    ActionServer,
    ClientGoal,
    GoalStatus,
    ServerGoal,
)
from robot_nodes.runtime.bus import BusConfig, open_router, open_session
from robot_nodes.runtime.node import Node, Publisher, Subscription, header, run, stamp_now
from robot_nodes.runtime.param_client import ParameterClient
from robot_nodes.runtime.parameters import ParameterError, ParameterStore, param
from robot_nodes.runtime.services import ServiceError, ServiceServer, call_service

__all__ = [
    "ActionClient",
    "ActionError",
    "ActionServer",
    "BusConfig",
    "ClientGoal",
    "GoalStatus",
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
