"""The plots: their status and the topics plotted (/api/plots), and, through the dashboard's origin, rerun's web
viewer (GET /plots/viewer/...) and its data stream.

rerun's server listens on loopback only (server.rerun_server); the browser reaches it only here, so the dashboard's
checks of Host, Origin and credential cover the plots too.

The viewer reads its data with gRPC-web: POSTs to ``/rerun.sdk_comms.v1alpha1.MessageProxyService/<method>`` on
the origin of the URL it is given, answered with a body that streams as long as the recording grows. rerun 0.41's
viewer accepts no path before ``/proxy`` in that URL, so the relay sits at rerun's own path on this server and the
panel hands the viewer ``rerun+http://<this server>/proxy``. Only the reading methods pass, so no page can write
into the plots. The body is relayed chunk by chunk, each read from rerun only after the browser took the last:
a slow browser holds back rerun's stream instead of filling the dashboard's memory; and the relay ends when the
browser goes away, even while rerun has nothing to send (Starlette listens for the disconnect under uvicorn's ASGI
2.3; tests/test_views_through_dashboard.py checks it).

rerun's viewer page links Google Fonts, and its wasm asks tel.rerun.io (usage analytics), api.github.com (newest
release) and app.rerun.io (examples). Offline these fail with console noise; at a venue with internet they would
leave the team's laptop. Served through here, the browser itself refuses every request that is not to this
server, and the font links are dropped from the page. Same origin as the dashboard, too, so the panel embeds it
without cross-origin rules.

The viewer's files change only with the rerun-sdk version: each carries an ETag of that version, and a browser
that has the file already gets 304 at once instead of another 43 MB of wasm read through the proxy.
"""

from __future__ import annotations

import re
from functools import cache
from importlib.metadata import version
from typing import TYPE_CHECKING, Any

import httpx
from fastapi import APIRouter, Depends, HTTPException, Request
from fastapi.responses import Response, StreamingResponse
from pydantic import BaseModel
from starlette.background import BackgroundTask

from server.deps import get_state, require_token
from server.loopback_ports import LOOPBACK
from server.state import ServerState

if TYPE_CHECKING:
    from server.plots import PlotFeed

router = APIRouter(tags=["plots"])

VIEWER = "/plots/viewer"
GRPC_SERVICE = "/rerun.sdk_comms.v1alpha1.MessageProxyService"  # rerun's log-message proxy, as its viewer calls it
READ_METHODS = frozenset({"ReadMessages", "ReadTables"})
MAX_GRPC_REQUEST_BYTES = 64 * 1024  # a read request is a few bytes
_PATH = re.compile(r"^[A-Za-z0-9_.-]*$")  # the viewer's files sit in one flat folder
_FONT_LINKS = re.compile(r"<link\b[^>]*https://fonts\.(?:googleapis|gstatic)\.com[^>]*>", re.S)
_PASSED_HEADERS = ("content-type",)
_GRPC_REQUEST_HEADERS = ("content-type", "x-grpc-web", "grpc-timeout", "grpc-accept-encoding", "x-user-agent")
_GRPC_RESPONSE_HEADERS = ("content-type", "grpc-status", "grpc-message", "grpc-encoding", "grpc-accept-encoding")
NOSNIFF = {"X-Content-Type-Options": "nosniff"}


@cache
def _etag(path: str) -> str:
    return f'"rerun-{version("rerun-sdk")}-{path or "index.html"}"'


def content_security_policy() -> str:
    """Everything from this server (the data stream too); nothing from elsewhere; framed only by the dashboard."""
    return "; ".join([
        "default-src 'self'",
        "script-src 'self' 'unsafe-inline' 'unsafe-eval' 'wasm-unsafe-eval'",  # the page's inline loader, wasm
        "style-src 'self' 'unsafe-inline'",
        "img-src 'self' data: blob:",
        "font-src 'self' data:",
        "worker-src 'self' blob:",
        "connect-src 'self' data: blob:",
        "frame-ancestors 'self'",
    ])


class PlotTopic(BaseModel):
    robot: str = "*"
    topic: str
    plotted: bool = True


class PlottedTopic(BaseModel):
    robot: str
    topic: str


class PlotsStatus(BaseModel):
    """What the viewer is fed; with the plots off, only ``logged`` (0) and ``robots`` (empty)."""

    logged: int
    robots: list[str]
    web_port: int | None = None  # rerun's loopback ports (a native viewer on this laptop can read the gRPC one)
    grpc_port: int | None = None
    server_running: bool | None = None
    state_changes: int | None = None
    newest_sent_s: float | None = None  # the newest stamp sent to rerun (s since the epoch)
    series: int | None = None
    topics: dict[str, list[str]] | None = None  # per robot, the topics plotted
    chosen: list[PlottedTopic] | None = None  # chosen on the page (robot "*": every robot)
    all_topics: bool | None = None  # --plots-all-topics: every topic is plotted


def _plots(state: ServerState) -> PlotFeed:
    if state.plots is None:
        raise HTTPException(404, "plots are off (start the server with --plots)")
    return state.plots


@router.get("/api/plots", response_model=PlotsStatus, response_model_exclude_unset=True)
def plots_status(state: ServerState = Depends(get_state)) -> dict[str, Any]:
    """Whether plots are served, and how many messages the rerun viewer has been fed."""
    return state.plots.status() if state.plots is not None else {"logged": 0, "robots": []}


@router.post("/api/plots/topics", response_model=PlotsStatus, response_model_exclude_unset=True)
def plot_topic(choice: PlotTopic, state: ServerState = Depends(require_token)) -> dict[str, Any]:
    """Plots every numeric field of a topic (of one robot or all) from now on, or stops. Only the server's own
    viewer changes: allowed in match mode, as nothing goes to a robot."""
    plots = _plots(state)
    if not choice.topic.strip():
        raise HTTPException(422, "no topic given")
    plots.choose(choice.robot, choice.topic, choice.plotted)
    return plots.status()


@router.get(VIEWER + "/{path:path}")
async def viewer_file(path: str, request: Request, state: ServerState = Depends(get_state)) -> Response:
    plots = _plots(state)
    if not _PATH.match(path):
        raise HTTPException(404, f"no viewer file {path!r}")
    policy = {"Content-Security-Policy": content_security_policy(), **NOSNIFF}
    cached = {"ETag": _etag(path), "Cache-Control": "no-cache", **policy}
    if request.headers.get("if-none-match") == cached["ETag"]:
        return Response(status_code=304, headers=cached)
    url = f"http://{LOOPBACK}:{plots.urls()['web_port']}/{path}"
    try:
        async with httpx.AsyncClient(timeout=30.0) as client:
            upstream = await client.get(url)
    except httpx.HTTPError as exc:
        raise HTTPException(502, f"rerun's viewer server did not answer: {exc}") from exc
    body = upstream.content
    if path in ("", "index.html") and upstream.status_code == 200:
        body = _FONT_LINKS.sub("", upstream.text).encode()
    headers = {name: upstream.headers[name] for name in _PASSED_HEADERS if name in upstream.headers}
    headers.update(cached if upstream.status_code == 200 else policy)
    return Response(body, status_code=upstream.status_code, headers=headers)


@router.post(GRPC_SERVICE + "/{method}")
async def plots_data(method: str, request: Request, state: ServerState = Depends(get_state)) -> Response:
    """The viewer's gRPC-web read of the plots, relayed to rerun's server on loopback."""
    plots = _plots(state)
    if method not in READ_METHODS:
        raise HTTPException(404, f"{method!r}: the plots are read here, nothing else")
    body = bytearray()
    async for chunk in request.stream():
        body += chunk
        if len(body) > MAX_GRPC_REQUEST_BYTES:
            raise HTTPException(413, f"a plots request is at most {MAX_GRPC_REQUEST_BYTES} bytes")
    client = httpx.AsyncClient(timeout=httpx.Timeout(10.0, read=None))  # the stream may rest while robots do
    headers = {name: request.headers[name] for name in _GRPC_REQUEST_HEADERS if name in request.headers}
    try:
        upstream = await client.send(client.build_request(
            "POST", f"http://{LOOPBACK}:{plots.urls()['grpc_port']}{GRPC_SERVICE}/{method}", content=bytes(body),
            headers=headers), stream=True)
    except httpx.HTTPError as exc:
        await client.aclose()
        raise HTTPException(502, f"rerun's server did not answer: {exc}") from exc
    chunks = upstream.aiter_raw()

    async def close() -> None:
        await chunks.aclose()  # type: ignore[attr-defined]  # an async generator
        await upstream.aclose()
        await client.aclose()

    passed = {name: upstream.headers[name] for name in _GRPC_RESPONSE_HEADERS if name in upstream.headers}
    # Starlette ends the response when the browser disconnects, also while rerun sends nothing (tested)
    return StreamingResponse(chunks, status_code=upstream.status_code, background=BackgroundTask(close),
                             headers={**passed, **NOSNIFF, "Cache-Control": "no-store"})
