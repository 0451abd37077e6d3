"""VenueGuard: the ASGI middleware every request and WebSocket of the dashboard passes first.

In order: the ``Host`` must be a name this server is reached by (DNS rebinding); a browser request from
another site (``Origin``, or ``Sec-Fetch-Site`` where a browser sends no Origin) may fetch the page's files but
nothing else; every state-changing request (any method but GET/HEAD/OPTIONS, with or without a body) needs the
credential, and when the server listens beyond loopback so does reading data; a request body is at most
``max_body_bytes`` and JSON in it at most ``max_json_depth`` deep. Every response gets the security headers.
The routers still check for themselves whether an endpoint controls a robot (``server.deps``); this layer
makes sure nothing reaches them that a foreign page or a stranger sent.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Awaitable, Callable, MutableMapping
from dataclasses import dataclass
from typing import Any
from urllib.parse import parse_qsl, urlencode, urlsplit

from server.security.credentials import Credentials
from server.security.hosts import AllowedHosts, host_name_of
from wire.json_limits import MAX_DEPTH, JsonLimitError, check_json_depth

log = logging.getLogger(__name__)
Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]

SAFE_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})
# paths that carry robot data or act; everything else is the page's own static files. The 3D view (viser) and
# the plots (rerun's viewer and its gRPC-web stream, at the path rerun's viewer insists on) come through here.
DATA_PREFIXES = ("/api/", "/ws", "/plots/", "/robot3d", "/rerun.", "/openapi.json")
# readable without the credential even beyond loopback: the page needs them to show that it is locked
OPEN_READS = frozenset({"/api/config", "/api/session"})
OPEN_WRITES = frozenset({"/api/session"})  # showing the token is how a browser gets the credential

APP_CSP = "; ".join([
    "default-src 'self'",
    "script-src 'self'",  # no inline script, no eval: markup that slips into the page cannot run
    "style-src 'self' 'unsafe-inline'",  # panels size elements through style attributes
    "img-src 'self' data: blob:",
    "font-src 'self' data:",
    "connect-src 'self'",
    "worker-src 'self' blob:",
    "object-src 'none'",
    "base-uri 'none'",
    "form-action 'self'",
    "frame-ancestors 'self'",
])


def is_data_path(path: str) -> bool:
    return path.startswith(DATA_PREFIXES) or path in ("/ws", "/api")


@dataclass(slots=True)
class VenuePolicy:
    """What the guard allows; built from the server's configuration."""

    hosts: AllowedHosts
    credentials: Credentials
    allowed_origins: frozenset[str] = frozenset()  # "http://name:port" besides the server's own origin
    reads_need_credential: bool = False  # True when the server listens beyond loopback
    max_body_bytes: int = 4 << 20  # an animation file is ~50 kB; a parameter write a few hundred bytes
    max_json_depth: int = MAX_DEPTH
    content_security_policy: str = APP_CSP


def normalized_origin(origin: str) -> str | None:
    """scheme://host[:port] in lower case with default ports dropped; None for 'null' or a malformed origin."""
    parts = urlsplit(origin.strip().lower())
    if parts.scheme not in ("http", "https") or not parts.hostname or parts.path not in ("", "/"):
        return None
    try:
        port = parts.port
    except ValueError:
        return None
    default = 80 if parts.scheme == "http" else 443
    host = f"[{parts.hostname}]" if ":" in parts.hostname else parts.hostname
    return f"{parts.scheme}://{host}" + (f":{port}" if port not in (None, default) else "")


class Refusal(Exception):
    """A request the guard answers itself: status, the reason for the caller, extra headers."""

    def __init__(self, status: int, reason: str, headers: list[tuple[bytes, bytes]] | None = None) -> None:
        super().__init__(reason)
        self.status = status
        self.reason = reason
        self.headers = headers or []


class VenueGuard:
    """Pure ASGI middleware (so it sees WebSocket handshakes too, which HTTP middleware does not)."""

    def __init__(self, app: ASGIApp, policy: VenuePolicy) -> None:
        self.app = app
        self.policy = policy
        self.refused: dict[str, int] = {}  # reason class -> count, for the status API and the tests

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        headers = _headers(scope)
        try:
            self._check(scope, headers)
            if scope["type"] == "http" and scope["method"] not in SAFE_METHODS:
                receive = await self._limited_body(headers, receive)
        except Refusal as refusal:
            await self._refuse(scope, send, refusal)
            return
        if scope["type"] == "http" and scope["method"] == "GET" and not is_data_path(scope["path"]):
            login = self._login(scope, headers)
            if login is not None:
                await self._refuse(scope, send, login)
                return
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = False
        with_headers = self._with_headers(scope, send)

        async def tracked(message: Message) -> None:
            nonlocal started
            started = started or message["type"] == "http.response.start"
            await with_headers(message)

        try:
            await self.app(scope, receive, tracked)
        except Exception:
            if started:
                raise  # half an answer sent: the server closes the connection
            # Starlette's own 500 would go out around this middleware, without the security headers
            log.exception("%s %s failed", scope["method"], scope["path"])
            await self._refuse(scope, send, Refusal(500, "the server failed on this request; its log says why"))

    # -- the checks ---------------------------------------------------------------------------------------
    def _check(self, scope: Scope, headers: dict[str, str]) -> None:
        policy = self.policy
        if not policy.hosts.allows(host_name_of(headers.get("host", ""))):
            self._count("host")
            raise Refusal(421, f"this server does not answer to the host name {headers.get('host', '')!r} "
                               f"(a defence against DNS rebinding); it answers to {policy.hosts.describe()}; "
                               "more names with --allow-host")
        path = scope["path"]
        unsafe = scope["type"] == "websocket" or scope["method"] not in SAFE_METHODS
        guarded = unsafe or is_data_path(path)
        if guarded and self._foreign(scope, headers):
            self._count("origin")
            raise Refusal(403, f"requests from the web page at {headers.get('origin') or 'another site'} are "
                               "refused; only this dashboard's own page (or origins given with --allow-origin) "
                               "may use it")
        if scope["type"] == "http" and unsafe and path not in OPEN_WRITES:
            needed = "control"
        elif policy.reads_need_credential and is_data_path(path) and path not in OPEN_READS:
            needed = "reading"
        else:
            return
        if not policy.credentials.presented_by(headers):
            self._count("credential")
            raise Refusal(401, f"{needed} needs the credential: open the dashboard through the link printed at "
                               "start-up (it carries the token), or send 'Authorization: Bearer <token>'")

    def _foreign(self, scope: Scope, headers: dict[str, str]) -> bool:
        """True for a browser request made by a page of another origin."""
        origin = headers.get("origin")
        if origin is None:
            # browsers send no Origin on some cross-site GETs (<img>, <script>, navigation): Fetch Metadata tells
            return headers.get("sec-fetch-site", "same-origin") not in ("same-origin", "none")
        normal = normalized_origin(origin)
        if normal is None:
            return True
        return normal != self._own_origin(scope, headers) and normal not in self.policy.allowed_origins

    @staticmethod
    def _own_origin(scope: Scope, headers: dict[str, str]) -> str | None:
        scheme = {"ws": "http", "wss": "https"}.get(scope.get("scheme", "http"), scope.get("scheme", "http"))
        return normalized_origin(f"{scheme}://{headers.get('host', '')}")

    async def _limited_body(self, headers: dict[str, str], receive: Receive) -> Receive:
        """The whole body, read here (at most max_body_bytes) and checked, handed on as one message."""
        limit = self.policy.max_body_bytes
        declared = headers.get("content-length", "")
        if declared.isdigit() and int(declared) > limit:
            self._count("body")
            raise Refusal(413, f"request body of {declared} bytes is larger than the limit of {limit}")
        chunks: list[bytes] = []
        size = 0
        while True:
            message = await receive()
            if message["type"] == "http.disconnect":
                break
            chunk = message.get("body", b"")
            size += len(chunk)
            if size > limit:
                self._count("body")
                raise Refusal(413, f"request body larger than the limit of {limit} bytes")
            chunks.append(chunk)
            if not message.get("more_body", False):
                break
        body = b"".join(chunks)
        if "json" in headers.get("content-type", "") and body:
            try:
                check_json_depth(body, self.policy.max_json_depth)
            except JsonLimitError as exc:
                self._count("json")
                raise Refusal(400, str(exc)) from None
        sent = False

        async def replay() -> Message:
            nonlocal sent
            if sent:
                return await receive()  # http.disconnect when the client goes
            sent = True
            return {"type": "http.request", "body": body, "more_body": False}

        return replay

    def _login(self, scope: Scope, headers: dict[str, str]) -> Refusal | None:
        """A page opened with ?token=: the browser gets the session cookie and the address without the token."""
        query = parse_qsl(scope.get("query_string", b"").decode("latin-1"), keep_blank_values=True)
        tokens = [v for k, v in query if k == "token"]
        if not tokens:
            return None
        credentials = self.policy.credentials
        if not credentials.token_matches(tokens[-1]):
            self._count("credential")
            return Refusal(401, "this link's token is not this server's (was the server restarted with another "
                                "token?): open the link it printed at start-up")
        rest = urlencode([(k, v) for k, v in query if k != "token"])
        location = scope["path"] + (f"?{rest}" if rest else "")
        cookie = credentials.session_cookie(secure=scope.get("scheme") == "https")
        return Refusal(303, "signed in", [(b"location", location.encode()), (b"set-cookie", cookie.encode())])

    def _count(self, what: str) -> None:
        self.refused[what] = self.refused.get(what, 0) + 1

    # -- answers ------------------------------------------------------------------------------------------
    async def _refuse(self, scope: Scope, send: Send, refusal: Refusal) -> None:
        if scope["type"] == "websocket":
            if "websocket.http.response" in scope.get("extensions", {}):
                await send({"type": "websocket.http.response.start", "status": refusal.status,
                            "headers": [(b"content-type", b"application/json")]})
                await send({"type": "websocket.http.response.body",
                            "body": json.dumps({"detail": refusal.reason}).encode()})
            else:
                await send({"type": "websocket.close", "code": 1008, "reason": refusal.reason[:120]})
            return
        body = json.dumps({"detail": refusal.reason}).encode()
        head = [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode()),
                *refusal.headers, *self._security_headers(scope["path"], has_csp=False)]
        await send({"type": "http.response.start", "status": refusal.status, "headers": head})
        await send({"type": "http.response.body", "body": body})

    def _security_headers(self, path: str, has_csp: bool) -> list[tuple[bytes, bytes]]:
        out = [(b"x-content-type-options", b"nosniff"), (b"referrer-policy", b"no-referrer"),
               (b"x-frame-options", b"SAMEORIGIN"), (b"cross-origin-resource-policy", b"same-origin")]
        if not has_csp:
            out.append((b"content-security-policy", self.policy.content_security_policy.encode()))
        if is_data_path(path):
            out.append((b"cache-control", b"no-store"))
        return out

    def _with_headers(self, scope: Scope, send: Send) -> Send:
        if scope["type"] != "http":
            return send

        async def send_with_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                present = {name.lower() for name, _ in message.get("headers", [])}
                extra = [h for h in self._security_headers(scope["path"], b"content-security-policy" in present)
                         if h[0] not in present]
                message = {**message, "headers": [*message.get("headers", []), *extra]}
            await send(message)

        return send_with_headers


def _headers(scope: Scope) -> dict[str, str]:
    """Request headers by lower-case name (the last of repeated ones), decoded as latin-1 like HTTP does."""
    return {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope.get("headers", [])}
