"""The two names of the Foxglove WebSocket protocol, and what the guard does so that both reach the one SDK.

foxglove-sdk 0.30 answers only clients that offer ``foxglove.sdk.v1`` (HTTP 400 otherwise), but Lichtblick before its
pull request #819 and every client of the foxglove_bridge era offer only ``foxglove.websocket.v1``. The SDK's protocol
is that protocol (the ws-protocol spec, same JSON ops, same binary frames) plus what the spec does not have: the
playback messages (binary opcode 3 from the client, 5 from the server) and the remote-access ping. A client that
offers ``foxglove.websocket.v1`` alone is therefore served by the SDK as if it had offered ``foxglove.sdk.v1``: the
guard names ``foxglove.sdk.v1`` in the request it passes on, names ``foxglove.websocket.v1`` again in the SDK's answer,
and drops the one server message such a client does not know (PlaybackState, pushed during a replay;
@foxglove/ws-protocol reports it as "Unrecognized server opcode"). A client never asks for the others: it does not know
them. A client that offers both gets ``foxglove.sdk.v1``, as the SDK answers.
"""

from __future__ import annotations

import asyncio
import re
from collections.abc import Iterable
from enum import StrEnum

HEADER = "sec-websocket-protocol"
MAX_RESPONSE_HEAD = 16 << 10
PLAYBACK_STATE = 5  # the SDK's server binary opcode the ws-protocol spec does not define
_BINARY = 0x2
_CHUNK = 256 << 10


class Subprotocol(StrEnum):
    SDK = "foxglove.sdk.v1"
    WEBSOCKET = "foxglove.websocket.v1"


class NoSubprotocol(ValueError):
    """The client offered neither name (the SDK would answer 400 without saying why)."""


def offered(headers: Iterable[tuple[bytes, bytes]]) -> list[str]:
    """Every subprotocol the request offers, over all its Sec-WebSocket-Protocol headers, in order."""
    names = []
    for name, value in headers:
        if name.decode("latin-1").lower() == HEADER:
            names += [v.strip() for v in value.decode("latin-1").split(",") if v.strip()]
    return names


def chosen(names: list[str]) -> Subprotocol:
    """The SDK's own name when offered, else the older one; neither: NoSubprotocol."""
    if Subprotocol.SDK in names:
        return Subprotocol.SDK
    if Subprotocol.WEBSOCKET in names:
        return Subprotocol.WEBSOCKET
    raise NoSubprotocol(f"offer the WebSocket subprotocol {Subprotocol.SDK} or {Subprotocol.WEBSOCKET} (offered: "
                        f"{', '.join(names) or 'none'})")


def request_for_sdk(head: bytes) -> bytes:
    """The upgrade request as it came, with its subprotocol headers replaced by one naming ``foxglove.sdk.v1``.

    ``head`` is everything read up to the end of the request's headers (a WebSocket client sends nothing more before
    the server's answer; anything after them is kept as it came)."""
    end = head.index(b"\r\n\r\n") + 2
    lines = head[:end].split(b"\r\n")[:-1]
    kept = [line for line in lines if line.split(b":", 1)[0].strip().lower() != HEADER.encode()]
    return b"\r\n".join([*kept, f"Sec-WebSocket-Protocol: {Subprotocol.SDK}".encode()]) + b"\r\n" + head[end:]


def response_for_client(head: bytes) -> bytes:
    """The SDK's answer with the subprotocol named as the client offered it (``foxglove.websocket.v1``)."""
    return re.sub(rb"(?im)^(sec-websocket-protocol:[ \t]*)foxglove\.sdk\.v1[ \t]*\r$",
                  rb"\g<1>" + Subprotocol.WEBSOCKET.encode() + b"\r", head)


async def pass_to_websocket_v1(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> int:
    """Copies the SDK's side to a ``foxglove.websocket.v1`` client: the answer's subprotocol renamed, then frame by
    frame without PlaybackState. Returns how many frames it dropped (when the SDK closes)."""
    try:
        head = await reader.readuntil(b"\r\n\r\n")
    except (asyncio.IncompleteReadError, asyncio.LimitOverrunError):
        return 0
    writer.write(response_for_client(head))
    await writer.drain()
    if not head.startswith(b"HTTP/1.1 101"):  # refused by the SDK: its answer is all there is
        return 0
    dropped = 0
    try:
        while True:
            dropped += await _pass_frame(reader, writer)
    except asyncio.IncompleteReadError:
        return dropped


async def _pass_frame(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> int:
    """One WebSocket frame of the server (RFC 6455 section 5.2; a server's frames are not masked). The SDK writes a
    message as one frame, so a PlaybackState is one binary frame with FIN whose payload begins with its opcode."""
    start = await reader.readexactly(2)
    size = start[1] & 0x7F
    extended = b""
    if size == 126:
        extended = await reader.readexactly(2)
    elif size == 127:
        extended = await reader.readexactly(8)
    if extended:
        size = int.from_bytes(extended, "big")
    mask = await reader.readexactly(4) if start[1] & 0x80 else b""
    first = await reader.readexactly(1) if size else b""
    drop = start[0] & 0x80 and start[0] & 0x0F == _BINARY and first == bytes([PLAYBACK_STATE]) and not mask
    if not drop:
        writer.write(start + extended + mask + first)
    left = size - len(first)
    while left:
        chunk = await reader.read(min(left, _CHUNK))
        if not chunk:
            raise asyncio.IncompleteReadError(b"", left)
        left -= len(chunk)
        if not drop:
            writer.write(chunk)
            await writer.drain()  # a client that does not read slows the copy, as in the guard's own copy
    if drop:
        return 1
    await writer.drain()
    return 0
