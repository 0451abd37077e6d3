"""The Foxglove endpoint's front door: checks who connects, then passes the connection through to the SDK.

foxglove-sdk 0.30 accepts every WebSocket handshake: no token, no Host or Origin check. A web page the laptop's
browser opens could read every stream from ws://127.0.0.1:8765 (WebSockets are not bound by the same-origin
policy), and beyond loopback anyone at the venue could. So the SDK listens on loopback ports browsers refuse
(server.loopback_ports), and this guard listens where the dashboard listens (with TLS, ``wss://``, when given a
certificate). It reads the HTTP upgrade request (h11), answers it itself when refused, and otherwise hands the
request and then the raw bytes both ways to the SDK: it does not speak the Foxglove protocol and looks at no message,
except for a client of the older subprotocol (server.foxglove.subprotocols). The rules, as the dashboard's (DESIGN.md
section 11):

- the ``Host`` must be a name the server is reached by (DNS rebinding);
- with the token (``?token=`` in the URL, or ``Authorization: Bearer``) anyone may connect, and control;
- without it, only while the server listens on loopback, and only to watch: clients that send no ``Origin``
  (scripts, ROS tools), the desktop apps (Foxglove and Lichtblick desktop load their window from ``file://``, so
  Electron sends ``Origin: file://``), pages served on this machine (``http://localhost:*``, ``http://127.0.0.1:*``,
  ``http://[::1]:*``: the dashboard, a self-hosted Lichtblick) and origins given with ``--allow-origin``. Any other web
  page, and ``Origin: null`` (a sandboxed frame of any site, a local HTML file), needs the token.

The SDK has two servers behind the guard (server.foxglove.servers): a connection that showed the token reaches the
one that offers control (parameters, services, publishing cmd_vel, playback control), as the dashboard's control API
needs the credential; one without the token reaches the one that only shows.

Bytes pass in chunks; a client that does not read stops the guard reading from the SDK for it (``drain``), the
SDK's queue for that client then drops its oldest messages, and memory stays bounded.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket
import ssl
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import parse_qs, urlsplit

import h11

from server.foxglove.subprotocols import (
    NoSubprotocol,
    Subprotocol,
    chosen,
    offered,
    pass_to_websocket_v1,
    request_for_sdk,
)
from server.security.credentials import Credentials
from server.security.guard import normalized_origin
from server.security.hosts import AllowedHosts, host_name_of
from wire.machine import is_loopback

log = logging.getLogger(__name__)
MAX_REQUEST_BYTES = 16 << 10
REQUEST_TIMEOUT_S = 10.0
MAX_CLIENTS = 32  # Foxglove windows on one laptop; more is a flood
CHUNK = 256 << 10
DESKTOP_ORIGIN = "file://"  # what Electron sends for a window loaded from a file: the desktop apps


def watches_without_token(origin: str | None, allowed_origins: frozenset[str]) -> bool:
    """May a client sending this ``Origin`` watch without the token (the server listening on loopback)?

    No Origin: not a web page. ``file://``: a desktop app. A page served on this machine, or an origin given with
    --allow-origin. Never ``null`` nor any other page: a browser on this machine opens sites of anyone."""
    if origin is None:
        return True
    if origin.strip().lower() == DESKTOP_ORIGIN:
        return True
    normal = normalized_origin(origin)
    if normal is None:  # "null", malformed
        return False
    host = host_name_of(normal.split("://", 1)[1])
    return normal in allowed_origins or (host is not None and is_loopback(host))


class Refused(Exception):
    def __init__(self, status: int, reason: str) -> None:
        super().__init__(reason)
        self.status = status


@dataclass
class GuardPolicy:
    """Who may connect (built from the server's configuration by the endpoint)."""

    hosts: AllowedHosts
    credentials: Credentials
    allowed_origins: frozenset[str] = frozenset()
    token_needed: bool = False  # beyond loopback every connection needs the token

    def check(self, target: bytes, headers: dict[str, str]) -> bool:
        """Refused unless the handshake may pass (see module doc); True when it showed the token."""
        if not self.hosts.allows(host_name_of(headers.get("host", ""))):
            raise Refused(421, "this server does not answer that host name")
        query = parse_qs(urlsplit(target.decode("latin-1")).query)
        tokens = query.get("token")
        presented = tokens[0] if tokens else self.credentials.bearer_of(headers.get("authorization", ""))
        if presented is not None:
            if self.credentials.token_matches(presented):
                return True
            raise Refused(401, "wrong token")
        if self.token_needed:
            raise Refused(401, "the Foxglove endpoint listens beyond loopback: connect to the URL printed at start, "
                               "which carries the token (?token=<token>)")
        origin = headers.get("origin")
        if not watches_without_token(origin, self.allowed_origins):
            shown = (origin or "")[:100]
            raise Refused(403, f"a web page of another origin ({shown!r}) needs the token in the URL, "
                               "?token=<token> (or --allow-origin)")
        return False


@dataclass
class GuardCounters:
    accepted: int = 0
    with_token: int = 0  # of the accepted: passed to the SDK server that offers control
    websocket_v1: int = 0  # of the accepted: clients of the older subprotocol, foxglove.websocket.v1
    refused: dict[int, int] = field(default_factory=dict)  # HTTP status -> count


@dataclass
class SdkPorts:
    """Where the guard passes connections: the SDK server that only shows, and the one that offers control."""

    view: int = 0
    control: int = 0


class FoxgloveGuard:
    """Listens on (host, port) in a thread of its own and passes checked connections to the SDK's ports."""

    def __init__(self, policy: GuardPolicy, host: str, sdk_ports: SdkPorts,
                 tls: ssl.SSLContext | None = None) -> None:
        self.policy = policy
        self.host = host
        self.tls = tls  # wss://: the TLS handshake comes first, before the HTTP request is read
        self.sdk_ports = sdk_ports  # read at each connection: the endpoint replaces its servers (replay)
        self.port = 0
        self.counters = GuardCounters()
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_forever, name="foxglove guard", daemon=True)
        self._server: asyncio.Server | None = None
        self._clients: set[asyncio.Task[None]] = set()
        self.on_pass: Callable[[], None] | None = None  # called (on the guard's thread) for each connection passed on

    def start(self, port: int) -> None:
        """Binds ``port`` (OSError when taken; 0: any free port)."""
        self._thread.start()
        future = asyncio.run_coroutine_threadsafe(self._listen(port), self._loop)
        try:
            self.port = future.result(10)
        except BaseException:
            self.stop()
            raise

    async def _listen(self, port: int) -> int:
        tls: dict[str, Any] = {"ssl": self.tls, "ssl_handshake_timeout": REQUEST_TIMEOUT_S} if self.tls else {}
        self._server = await asyncio.start_server(self._serve, self.host, port, limit=MAX_REQUEST_BYTES, **tls)
        return int(self._server.sockets[0].getsockname()[1])

    def stop(self) -> None:
        if self._thread.is_alive():
            with contextlib.suppress(Exception):
                asyncio.run_coroutine_threadsafe(self._close(), self._loop).result(10)
            self._loop.call_soon_threadsafe(self._loop.stop)
            self._thread.join(10)
        self._loop.close()

    async def _close(self) -> None:
        if self._server is not None:
            self._server.close()
        for task in list(self._clients):
            task.cancel()
        await asyncio.gather(*self._clients, return_exceptions=True)

    # -- one connection ---------------------------------------------------------------------------------------
    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        task = asyncio.current_task()
        assert task is not None
        self._clients.add(task)
        try:
            _nodelay(writer)
            await self._handshake_and_pass(reader, writer)
        except (ConnectionError, asyncio.IncompleteReadError, TimeoutError, OSError):
            pass
        finally:
            self._clients.discard(task)
            writer.close()
            with contextlib.suppress(Exception):
                await writer.wait_closed()

    async def _handshake_and_pass(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        head = b""
        try:
            async with asyncio.timeout(REQUEST_TIMEOUT_S):
                request, head = await _read_request(reader)
            if len(self._clients) > MAX_CLIENTS:
                raise Refused(503, f"at most {MAX_CLIENTS} Foxglove clients at once")
            headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in request.headers}
            with_token = self.policy.check(request.target, headers)
            try:
                subprotocol = chosen(offered(request.headers))
            except NoSubprotocol as exc:
                raise Refused(400, str(exc)) from None
        except Refused as refusal:
            self.counters.refused[refusal.status] = self.counters.refused.get(refusal.status, 0) + 1
            writer.write(_response(refusal.status, str(refusal)))
            await writer.drain()
            return
        except (h11.RemoteProtocolError, ValueError):
            self.counters.refused[400] = self.counters.refused.get(400, 0) + 1
            writer.write(_response(400, "not an HTTP request"))
            await writer.drain()
            return
        self.counters.accepted += 1
        self.counters.with_token += with_token
        older = subprotocol is Subprotocol.WEBSOCKET
        self.counters.websocket_v1 += older
        if older:
            head = request_for_sdk(head)
        port = self.sdk_ports.control if with_token else self.sdk_ports.view
        up_reader, up_writer = await asyncio.open_connection("127.0.0.1", port)
        _nodelay(up_writer)
        if self.on_pass is not None:
            self.on_pass()
        try:
            up_writer.write(head)
            upstream = asyncio.create_task(_pass(reader, up_writer))
            downstream = asyncio.create_task(pass_to_websocket_v1(up_reader, writer) if older
                                             else _pass(up_reader, writer))
            done, pending = await asyncio.wait({upstream, downstream}, return_when=asyncio.FIRST_COMPLETED)
            for task in pending:
                task.cancel()
            # a side that ended with a reset connection is how a client leaves: taken, not logged as a lost error
            await asyncio.gather(*done, *pending, return_exceptions=True)
        finally:
            up_writer.close()


async def _read_request(reader: asyncio.StreamReader) -> tuple[h11.Request, bytes]:
    """The upgrade request and every byte read so far (passed on to the SDK as they came)."""
    parser = h11.Connection(h11.SERVER, max_incomplete_event_size=MAX_REQUEST_BYTES)
    head = b""
    while True:
        event = parser.next_event()
        if isinstance(event, h11.Request):
            return event, head
        if event is h11.NEED_DATA:
            chunk = await reader.read(4096)
            if not chunk:
                raise ConnectionError("closed before the request was complete")
            head += chunk
            parser.receive_data(chunk)
            continue
        raise ValueError(f"unexpected {event!r}")


async def _pass(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
    """Copies until the reader ends; waits for the writer's buffer to drain, so a slow reader slows the copy."""
    while True:
        chunk = await reader.read(CHUNK)
        if not chunk:
            return
        writer.write(chunk)
        await writer.drain()


def _response(status: int, reason: str) -> bytes:
    body = (reason + "\n").encode()
    phrase = {400: "Bad Request", 401: "Unauthorized", 403: "Forbidden", 421: "Misdirected Request",
              503: "Service Unavailable"}.get(status, "Refused")
    return (f"HTTP/1.1 {status} {phrase}\r\nContent-Type: text/plain; charset=utf-8\r\nContent-Length: {len(body)}"
            "\r\nConnection: close\r\n\r\n").encode() + body


def _nodelay(writer: asyncio.StreamWriter) -> None:
    sock = writer.get_extra_info("socket")
    if sock is not None:
        with contextlib.suppress(OSError):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
