"""The service server of a node: requests handled on the node's loop (wire.services)."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import zenoh

import schemas
from schemas.codec import Message
from wire import keys
from wire.services import service_types

if TYPE_CHECKING:
    from robot_nodes.runtime.loop import EventLoop


class ServiceServer:
    def __init__(self, session: zenoh.Session, loop: EventLoop, robot: str, service: str,
                 handler: Callable[[Any], Message]) -> None:
        self.request_type, self.response_type = service_types(service)
        self._key = keys.service_key(robot, service)
        self._handler = handler
        self._q = session.declare_queryable(self._key, lambda q: loop.call_soon(self._handle, q))

    def _handle(self, query: zenoh.Query) -> None:
        try:
            payload = query.payload.to_bytes() if query.payload is not None else b""
            request = schemas.decode(payload, self.request_type)
            response = self._handler(request)
            query.reply(self._key, schemas.encode(response))
        except Exception as exc:  # every failure goes back to the caller as text
            query.reply_err(f"{type(exc).__name__}: {exc}")
        finally:
            query.drop()

    def close(self) -> None:
        self._q.undeclare()
