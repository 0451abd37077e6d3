"""The WebSocket endpoint /ws: one hub subscriber per browser, frames as server.protocol defines them."""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import logging
import time

from fastapi import APIRouter, Depends, WebSocket, WebSocketDisconnect

from schemas.codec import SchemaError
from server import protocol
from server.deps import get_state
from server.hub import Subscriber
from server.link_health import robots_info
from server.state import ServerState

log = logging.getLogger(__name__)
router = APIRouter()
ROBOTS_PERIOD_S = 0.5
MAX_SUBSCRIPTIONS = 256  # per connection: bounds the work a client can make the hub do per message
_ids = itertools.count(1)


async def _read_requests(ws: WebSocket, sub: Subscriber) -> None:
    """Applies the client's subscribe/unsubscribe requests as they come."""
    while True:
        message = await ws.receive()
        if message["type"] == "websocket.disconnect":
            raise WebSocketDisconnect(message.get("code", 1000))
        try:
            if message.get("text") is None:
                raise protocol.ProtocolError("requests are JSON text frames, not binary")
            request = protocol.parse_client_frame(message["text"])
            if request["op"] == "subscribe" and len(sub.subscriptions) >= MAX_SUBSCRIPTIONS:
                raise protocol.ProtocolError(f"at most {MAX_SUBSCRIPTIONS} subscriptions per connection")
            if request["op"] == "subscribe":
                sub.subscribe(request["robot"], request["topic"], request.get("max_hz") or None)
            elif request["op"] == "unsubscribe":
                sub.unsubscribe(request["robot"], request["topic"])
            else:
                await ws.send_text(protocol.pong_frame(request.get("id")))
        except protocol.ProtocolError as exc:
            await ws.send_text(protocol.error_frame(str(exc)))
        except (ValueError, TypeError, RecursionError) as exc:  # a request we did not foresee: answer, stay up
            log.warning("websocket %s: request not handled: %r", sub.name, exc)
            await ws.send_text(protocol.error_frame(f"request not handled: {type(exc).__name__}"))


async def _send_frames(ws: WebSocket, sub: Subscriber, state: ServerState) -> None:
    """Sends what the subscriber queued; if this browser is slow, the hub drops its oldest frames meanwhile."""
    next_robots = 0.0
    while True:
        await sub.wait(timeout=ROBOTS_PERIOD_S)
        now = time.monotonic()
        if now >= next_robots:
            next_robots = now + ROBOTS_PERIOD_S
            await ws.send_text(protocol.robots_frame(robots_info(state)))
        texts: list[str] = []
        for msg in sub.drain():
            try:
                frame = protocol.frame_of(msg)
            except SchemaError as exc:
                state.hub.decode_errors += 1
                log.debug("not sent: %s", exc)
                continue
            if isinstance(frame, str):
                texts.append(frame)
            else:
                await ws.send_bytes(frame)
        if texts:  # one WebSocket frame for what queued up meanwhile: the per-frame cost dominates
            await ws.send_text(texts[0] if len(texts) == 1 else protocol.batch_frame(texts))


@router.websocket("/ws")
async def websocket_endpoint(ws: WebSocket, state: ServerState = Depends(get_state)) -> None:
    await ws.accept()
    sub = state.hub.subscribe(name=f"ws{next(_ids)}", maxlen=state.config.queue_size)
    await ws.send_text(protocol.hello_frame(state.config.match_mode))
    tasks = [asyncio.create_task(_read_requests(ws, sub)), asyncio.create_task(_send_frames(ws, sub, state))]
    code = 1000
    try:
        done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        for task in done:
            exc = task.exception()
            if exc is not None and not isinstance(exc, WebSocketDisconnect | RuntimeError | OSError):
                log.warning("websocket %s closed: %r", sub.name, exc)
                code = 1011
    finally:
        sub.close()
        for task in tasks:
            task.cancel()
            with contextlib.suppress(BaseException):
                await task
        with contextlib.suppress(Exception):  # never leave a browser without a close frame
            await ws.close(code)
