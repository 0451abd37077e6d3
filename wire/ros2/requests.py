"""Service servers and clients on rmw_zenoh's wire whose replies may come later, from another thread.

endpoints.Ros2Service answers inside the queryable's callback; an action cannot: its get_result is answered when
the goal ends, and a node decides on goals on its own loop. Here a request is handed on as a ``PendingRequest``
that is answered (once) whenever its owner is ready, with the reply attachment rmw_zenoh expects (the request's
sequence number and the client's GID). The client side asks without blocking and hears back through callbacks.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Any

import zenoh

from wire.ros2.attachment import Attachment, decode_attachment
from wire.ros2.errors import Ros2WireError
from wire.ros2.liveliness import Entity

log = logging.getLogger(__name__)


class PendingRequest:
    """One request a server has not answered yet: its CDR payload and attachment; reply or fail exactly once."""

    def __init__(self, query: zenoh.Query, keyexpr: str, attachment: Attachment) -> None:
        self.payload = query.payload.to_bytes() if query.payload is not None else b""
        self.attachment = attachment
        self._query: zenoh.Query | None = query
        self._keyexpr = keyexpr
        self._lock = threading.Lock()

    @property
    def answered(self) -> bool:
        return self._query is None

    def _take(self) -> zenoh.Query | None:
        with self._lock:
            query, self._query = self._query, None
        return query

    def reply(self, response: bytes) -> None:
        query = self._take()
        if query is None:
            return
        reply = Attachment(self.attachment.sequence_number, time.time_ns(), self.attachment.gid)
        try:
            query.reply(self._keyexpr, response, attachment=reply.encode())
        finally:
            query.drop()  # the client's get ends here, not when Python collects the query

    def reply_error(self, why: str) -> None:
        query = self._take()
        if query is None:
            return
        try:
            query.reply_err(why)
        finally:
            query.drop()


class RequestServer:
    """A service server as rmw_zenoh's (a complete queryable and its SS token) that hands every request with a
    valid attachment to ``on_request`` on a Zenoh thread; a request without one is dropped and counted, as
    rmw_zenoh drops it."""

    def __init__(self, session: zenoh.Session, entity: Entity, on_request: Callable[[PendingRequest], None]) -> None:
        assert entity.topic is not None
        self.entity = entity
        self.dropped = 0
        self._keyexpr = entity.topic.keyexpr
        self._on_request = on_request
        self._queryable: Any = session.declare_queryable(self._keyexpr, self._on_query, complete=True)
        self._token = session.liveliness().declare_token(entity.token)

    def _on_query(self, query: zenoh.Query) -> None:
        try:
            if query.attachment is None:
                raise Ros2WireError("request without an attachment")
            attachment = decode_attachment(query.attachment.to_bytes())
        except Ros2WireError as exc:
            self.dropped += 1
            if self.dropped == 1:
                log.warning("dropping requests on %s that rmw_zenoh would drop too (further ones only counted): %s",
                            self._keyexpr, exc)
            query.drop()
            return
        self._on_request(PendingRequest(query, self._keyexpr, attachment))

    def close(self) -> None:
        self._token.undeclare()
        self._queryable.undeclare()


ReplyCallback = Callable[[bytes], None]
FailCallback = Callable[[str, bool], None]  # why, and whether a server answered at all


class RequestClient:
    """A service client as rmw_zenoh's (a get to every complete queryable, its SC token). ``ask`` returns at once;
    exactly one of ``on_reply(cdr)`` and ``on_fail(why, heard)`` runs later on a Zenoh thread."""

    def __init__(self, session: zenoh.Session, entity: Entity) -> None:
        assert entity.topic is not None
        self.entity = entity
        self.gid = entity.gid
        self._session = session
        self._keyexpr = entity.topic.keyexpr
        self._sequence_number = 0
        self._lock = threading.Lock()
        self._token = session.liveliness().declare_token(entity.token)

    def ask(self, request: bytes, on_reply: ReplyCallback, on_fail: FailCallback, timeout_s: float) -> None:
        with self._lock:
            self._sequence_number += 1
            sent = Attachment(self._sequence_number, time.time_ns(), self.gid)
        answered = threading.Event()
        name = self.entity.topic.name if self.entity.topic is not None else self._keyexpr

        def reply(reply: zenoh.Reply) -> None:
            if answered.is_set():
                return  # a second server's answer (two servers of one name): the first counts, as in rmw_zenoh
            answered.set()
            if reply.ok is None:
                why = reply.err.payload.to_string() if reply.err is not None else "an empty reply"
                # a router's "Timeout": no server answered in time (a busy machine), not a server's refusal
                on_fail(f"{name}: {why}", why != "Timeout")
                return
            sample = reply.ok
            try:
                if sample.attachment is None:
                    raise Ros2WireError("a reply without an attachment")
                got = decode_attachment(sample.attachment.to_bytes())
                if got.sequence_number != sent.sequence_number or got.gid != self.gid:
                    raise Ros2WireError(f"a reply to request {got.sequence_number}, not to {sent.sequence_number}")
            except Ros2WireError as exc:
                on_fail(f"{name}: {exc}", True)
                return
            on_reply(sample.payload.to_bytes())

        def done() -> None:
            if not answered.is_set():
                answered.set()
                on_fail(f"{name}: no server answered within {timeout_s} s", False)

        # every complete server, each reply passed on as it comes (rmw_zenoh's querier: ALL_COMPLETE, no
        # consolidation)
        self._session.get(self._keyexpr, zenoh.handlers.Callback(reply, done), target=zenoh.QueryTarget.ALL_COMPLETE,
                          consolidation=zenoh.ConsolidationMode.NONE, payload=request, attachment=sent.encode(),
                          timeout=timeout_s)

    def close(self) -> None:
        self._token.undeclare()
