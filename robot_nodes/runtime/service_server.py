"""The service server of a node: a ROS 2 service of the robot (``/robot1/manual_penalize``) as rmw_zenoh serves it
(a complete queryable, the SS token, attachments; wire.ros2.endpoints), its requests handled on the node's loop."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import zenoh

import schemas
from schemas.codec import Message
from wire.ros2.attachment import Attachment
from wire.ros2.endpoints import Ros2Service
from wire.ros2.liveliness import Entity, EntityKind, NodeInfo
from wire.ros2.qos import QoS
from wire.ros2.robots import service_key
from wire.services import service_types

if TYPE_CHECKING:
    from robot_nodes.runtime.loop import EventLoop

# rmw_qos_profile_services_default: reliable, volatile, keep last 10
SERVICES_QOS = QoS(depth=10)


class ServiceServer:
    def __init__(self, session: zenoh.Session, loop: EventLoop, node: NodeInfo, node_id: int, entity_id: int,
                 robot: str, service: str, handler: Callable[[Any], Message]) -> None:
        self.request_type, self.response_type = service_types(service)
        self._handler = handler
        topic = service_key(robot, service, node.domain_id)
        entity = Entity(str(session.zid()), node_id, entity_id, EntityKind.SERVICE, node, topic, SERVICES_QOS)
        self._service = Ros2Service(session, entity, self._handle, dispatch=loop.call_soon)

    @property
    def bad_requests(self) -> int:
        """Requests without an attachment, that did not decode, or that the handler failed on."""
        return self._service.dropped + self._service.failed

    def _handle(self, payload: bytes, _attachment: Attachment) -> bytes:
        # every failure (a payload that is no request, a handler that raises) goes back to the caller as text
        return schemas.encode(self._handler(schemas.decode(payload, self.request_type)))

    def close(self) -> None:
        self._service.close()
