"""Foxglove's Services capability: each live robot's ``/<robot>/manual_penalize`` and ``/<robot>/play_animation``.

Requests and responses are CDR with ros2msg schemas (humanoid_league_msgs/srv/ManualPenalize, and the PlayAnimation
action's goal and result), so Foxglove's Service Call panel fills them in by field. They do what the dashboard's
buttons do: manual_penalize calls the HCM's service (wire.services.call_service), play_animation sends the
PlayAnimation goal through the lab tools (server.lab.LabTools.play) and answers once the robot accepted or rejected
it (``successful`` and the reason in ``message``); an ``hcm: true`` goal is refused (it would preempt everything, and
only the HCM itself may send it). A robot that has been silent gets nothing (as the dashboard's robot_on_link).

Lab only, and only for clients that showed the token (server.foxglove.servers).
"""

from __future__ import annotations

import time
from typing import Any

import foxglove

import schemas
from server.lab import lab_tools
from server.state import ServerState
from wire.actions import ActionError, action_types
from wire.services import ServiceError, call_service, service_types

PENALIZE, PLAY = "manual_penalize", "play_animation"
SERVED_BY = {PENALIZE: "manual_penalize", PLAY: "animation"}  # the robot's service or action each one calls
TIMEOUT_S = 3.0
ENCODING = "cdr"


class ServiceRefused(RuntimeError):
    """A service call the endpoint does not pass on; the client gets the text."""


def service_name(robot: str, service: str) -> str:
    return f"/{robot}/{service}"


def _schema(typename: str) -> foxglove.MessageSchema:
    return foxglove.MessageSchema(encoding=ENCODING, schema=foxglove.Schema(
        name=typename, encoding="ros2msg", data=schemas.msgdef(typename).encode()))


class RobotServices:
    """Builds the services of a robot; their handlers run on the SDK's threads and may block."""

    def __init__(self, state: ServerState) -> None:
        self.state = state
        self.calls = 0

    def service(self, robot: str, name: str) -> foxglove.Service:
        """``/<robot>/manual_penalize`` or ``/<robot>/play_animation``."""
        if name == PENALIZE:
            request, response = service_types(PENALIZE)
            return foxglove.Service(service_name(robot, PENALIZE), schema=foxglove.ServiceSchema(
                schemas.SERVICES[PENALIZE].type, request=_schema(request), response=_schema(response)),
                handler=lambda call: self._penalize(robot, call))
        goal, _, result = action_types("animation")
        return foxglove.Service(service_name(robot, PLAY), schema=foxglove.ServiceSchema(
            schemas.ACTIONS["animation"].type, request=_schema(goal), response=_schema(result)),
            handler=lambda call: self._play(robot, call))

    def _decode(self, robot: str, request: Any, typename: str) -> Any:
        self.calls += 1
        if request.encoding != ENCODING:
            raise ServiceRefused(f"requests are {ENCODING}, not {request.encoding}")
        seen = self.state.hub.robots.get(robot)
        if seen is not None and seen.last_received and \
                time.monotonic() - seen.last_received > self.state.config.stale_after_s:
            raise ServiceRefused(f"{robot} has been silent (link lost?): nothing was sent")
        try:
            return schemas.decode(bytes(request.payload), typename)
        except schemas.SchemaError as exc:
            raise ServiceRefused(f"not a {typename}: {exc}") from None

    def _penalize(self, robot: str, request: Any) -> bytes:
        message = self._decode(robot, request, service_types(PENALIZE)[0])
        try:
            response = call_service(self.state.link.session(), robot, PENALIZE, message, timeout=TIMEOUT_S)
        except ServiceError as exc:
            raise ServiceRefused(str(exc)) from None
        return schemas.encode(response)

    def _play(self, robot: str, request: Any) -> bytes:
        goal_type, _, result_type = action_types("animation")
        goal = self._decode(robot, request, goal_type)
        if goal.hcm:
            raise ServiceRefused("hcm goals come from the HCM only: send hcm false")
        try:
            handle = lab_tools(self.state).play(robot, str(goal.animation))
        except ActionError as exc:
            raise ServiceRefused(str(exc)) from None
        message = "accepted: playing" if handle.accepted else f"rejected: {handle.reason}"
        return schemas.encode(schemas.make(result_type, successful=bool(handle.accepted), message=message))
