"""Services of the table (``manual_penalize``) as ROS 2 services of a robot (``/robot1/manual_penalize``) on
rmw_zenoh's wire, the caller's side: the request goes out from the session's caller node (wire.ros2.caller) with
the attachment rmw_zenoh servers check, and the reply must carry the request's sequence number."""

from __future__ import annotations

import time
from typing import Any

import zenoh

import schemas
from schemas.codec import Message
from wire import keys
from wire.ros2 import robots as ros2_robots
from wire.ros2.caller import caller
from wire.ros2.endpoints import Ros2ServiceError, Ros2ServiceUnanswered


class ServiceError(Exception):
    """A service refused a request or did not answer; the text says why."""


def service_types(service: str) -> tuple[str, str]:
    base = schemas.SERVICES[service].type
    return f"{base}_Request", f"{base}_Response"


RETRY_S = 0.05


def call_service(session: zenoh.Session, robot: str, service: str, request: Message, timeout: float = 5.0) -> Any:
    """Blocking call; ServiceError with the server's reason on failure.

    A server that just started may not be routed to us yet, so a call nobody answered is made again until the
    timeout.
    """
    _, response_type = service_types(service)
    try:
        topic = ros2_robots.service_key(robot, service, keys.domain_id())
    except ValueError as exc:  # a robot id that is no ROS 2 namespace has no services
        raise ServiceError(str(exc)) from None
    client = caller(session, topic.domain_id).client(topic.name, topic.ros_type, topic.type_hash)
    payload = schemas.encode(request)
    deadline = time.monotonic() + timeout
    while True:
        remaining = max(RETRY_S, deadline - time.monotonic())
        try:
            response, _ = client.call(payload, timeout_s=remaining)
        except Ros2ServiceUnanswered:
            if time.monotonic() >= deadline:
                break
            time.sleep(RETRY_S)
            continue
        except Ros2ServiceError as exc:  # the server's error reply: its reason
            raise ServiceError(str(exc)) from None
        return schemas.decode(response, response_type)
    raise ServiceError(f"no answer from service {service!r} of robot {robot!r} within {timeout} s")
