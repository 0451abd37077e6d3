"""Services over Zenoh: a queryable per service, CDR request in, CDR response or an error text out."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import zenoh

import schemas
from robot_nodes.runtime import keys

if TYPE_CHECKING:
    from robot_nodes.runtime.loop import EventLoop


class ServiceError(Exception):
    """A service refused a request or did not answer; the text says why."""


def _types(service: str) -> tuple[str, str]:
    base = schemas.SERVICES[service].type
    return f"{base}_Request", f"{base}_Response"


class ServiceServer:
    def __init__(self, session: zenoh.Session, loop: EventLoop, robot: str, service: str,
                 handler: Callable[[Any], Any]) -> None:
        self.request_type, self.response_type = _types(service)
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


def call_service(session: zenoh.Session, robot: str, service: str, request: Any, timeout: float = 5.0) -> Any:
    """Blocking call; ServiceError with the server's reason on failure.

    A server that just started may not be routed to us yet, so an empty answer is asked again until the timeout.
    """
    _, response_type = _types(service)
    payload = schemas.encode(request)
    deadline = time.monotonic() + timeout
    while True:
        remaining = max(0.05, deadline - time.monotonic())
        for reply in session.get(keys.service_key(robot, service), payload=payload, timeout=remaining):
            if reply.ok is not None:
                return schemas.decode(reply.ok.payload.to_bytes(), response_type)
            raise ServiceError(reply.err.payload.to_string() if reply.err is not None else "service error")
        if time.monotonic() >= deadline:
            break
        time.sleep(0.05)
    raise ServiceError(f"no answer from service {service!r} of robot {robot!r} within {timeout} s")
