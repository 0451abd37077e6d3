"""Services over Zenoh, the protocol and the caller: a queryable per service, CDR request in, CDR response or an
error text out."""

from __future__ import annotations

import time
from typing import Any

import zenoh

import schemas
from schemas.codec import Message
from wire import keys


class ServiceError(Exception):
    """A service refused a request or did not answer; the text says why."""


def service_types(service: str) -> tuple[str, str]:
    base = schemas.SERVICES[service].type
    return f"{base}_Request", f"{base}_Response"


ZENOH_TIMEOUT = "Timeout"  # the error reply Zenoh itself gives a query that no queryable answered in time


def call_service(session: zenoh.Session, robot: str, service: str, request: Message, timeout: float = 5.0) -> Any:
    """Blocking call; ServiceError with the server's reason on failure.

    A server that just started may not be routed to us yet, so an empty answer is asked again until the timeout.
    """
    _, response_type = service_types(service)
    payload = schemas.encode(request)
    deadline = time.monotonic() + timeout
    while True:
        remaining = max(0.05, deadline - time.monotonic())
        for reply in session.get(keys.service_key(robot, service), payload=payload, timeout=remaining):
            if reply.ok is not None:
                return schemas.decode(reply.ok.payload.to_bytes(), response_type)
            reason = reply.err.payload.to_string() if reply.err is not None else "service error"
            if reason == ZENOH_TIMEOUT:  # Zenoh's own reply when nobody answered in time: not the server's reason
                continue
            raise ServiceError(reason)
        if time.monotonic() >= deadline:
            break
        time.sleep(0.05)
    raise ServiceError(f"no answer from service {service!r} of robot {robot!r} within {timeout} s")
