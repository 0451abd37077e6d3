"""The 3D view: its status (/api/robot3d), and viser's client page and its WebSocket (/robot3d/view/), passed through
from viser on loopback.

viser listens on loopback only and refuses browsers (server.robot3d), so the dashboard's origin is the one way in,
and the dashboard's checks of Host, Origin and credential cover the 3D view too. viser's client derives its
WebSocket from the page's address (``ws://<page path>`` without the trailing slash), so the socket is served on
/robot3d/view itself.

The page is one file: an inline loader unpacks a zstd-compressed module script and stylesheet and inserts them.
The Content-Security-Policy allows exactly those two inline scripts, by their SHA-256 (computed here from the page
viser serves), so no other inline script or event handler runs; WebAssembly (the zstd decoder, the sorters); blob:
workers (viser's WebSocket and sorting workers); nothing from another origin; and only the dashboard may frame it.
Two allowances viser needs: 'unsafe-eval', as its bundled Emscripten modules build their bindings with Function()
when they load (without it every page load throws), and inline styles, which its UI library writes at run time.

Frames pass both ways as they are (binary or text), one at a time: the next frame is read from one side only after
the other side took the last one, so a slow browser holds back viser instead of filling the proxy's memory.
Closing either side closes the other.
"""

from __future__ import annotations

import asyncio
import base64
import contextlib
import hashlib
import logging
import re
from functools import lru_cache
from typing import Any

import httpx
import numpy as np
from fastapi import APIRouter, Depends, HTTPException, WebSocket
from fastapi.responses import RedirectResponse, Response
from pydantic import BaseModel

from server.deps import get_state, require_token
from server.loopback_ports import LOOPBACK
from server.state import Robot3D, ServerState

log = logging.getLogger(__name__)
router = APIRouter(tags=["robot3d"])

PREFIX = "/robot3d/view"
_PATH = re.compile(r"^[A-Za-z0-9_.-]*$")  # viser's client is a flat folder (one file today)
_PASSED_HEADERS = ("content-type",)
MAX_FRAME_BYTES = 64 * 1024 * 1024  # viser's own limit for what it receives is 50 MB; meshes come as one frame
QUEUED_FRAMES = 4  # frames read ahead from viser while the browser is busy: the proxy's memory per connection
_UNSENDABLE_CLOSE_CODES = (1005, 1006, 1015)  # reported by a peer, never sent in a close frame

_SCRIPT = re.compile(r"<script\b([^>]*)>(.*?)</script\s*>", re.S | re.I)
_DATA_ATTRIBUTE = re.compile(r'\bdata-([a-z]+)="([^"]*)"')
_LOADER_ALPHABET = re.compile(r'\bconst A="((?:[^"\\]|\\.)*)"')


def _sha256(text: str) -> str:
    return "'sha256-" + base64.b64encode(hashlib.sha256(text.encode()).digest()).decode() + "'"


def _decode_packed(text: str, alphabet: str) -> bytes:
    """The byte string viser's loader packs into an attribute: 5 characters of base len(alphabet) per 4 bytes."""
    base = len(alphabet)
    lookup = np.zeros(128, dtype=np.uint64)
    lookup[[ord(c) for c in alphabet]] = np.arange(base, dtype=np.uint64)
    codes = lookup[np.frombuffer(text.encode("ascii"), dtype=np.uint8)]
    whole = len(codes) // 5
    groups = codes[: whole * 5].reshape(whole, 5)
    values = np.zeros(whole, dtype=np.uint64)
    for column in range(5):
        values = values * np.uint64(base) + groups[:, column]
    out = (values & np.uint64(0xFFFFFFFF)).astype(">u4").tobytes()
    rest = [int(c) for c in codes[whole * 5:]]
    if rest:
        value = 0
        for code in rest:
            value = value * base + code
        out += (value % 256 ** (len(rest) - 1)).to_bytes(len(rest) - 1, "big")
    return out


def _unpacked_script(attributes: dict[str, str], loader: str) -> str:
    """The module script viser's loader inserts: the zstd payload of ``data-p``, its part after ``data-ss``."""
    import zstandard

    match = _LOADER_ALPHABET.search(loader)
    if match is None:
        raise ValueError("viser's loader has no alphabet")
    alphabet = re.sub(r"\\(.)", r"\1", match.group(1))
    styles, code = int(attributes["ss"]), int(attributes["cs"])
    unpacked = zstandard.ZstdDecompressor().decompress(_decode_packed(attributes["p"], alphabet),
                                                       max_output_size=styles + code)
    # the loader decodes with TextDecoder: invalid UTF-8 replaced, a leading BOM dropped
    return unpacked[styles:styles + code].decode("utf-8", errors="replace").removeprefix("\ufeff")


@lru_cache(maxsize=4)
def page_script_hashes(page: str) -> tuple[str, ...]:
    """CSP hash sources of the page's inline scripts and of the script viser's loader inserts from them."""
    hashes: list[str] = []
    for match in _SCRIPT.finditer(page):
        attributes = dict(_DATA_ATTRIBUTE.findall(match.group(1)))
        if re.search(r"\bsrc\s*=", match.group(1)):
            continue  # a file of this server: 'self'
        hashes.append(_sha256(match.group(2)))
        if {"p", "ss", "cs"} <= attributes.keys():
            try:
                hashes.append(_sha256(_unpacked_script(attributes, match.group(2))))
            except Exception as exc:  # a viser whose page packs differently: its script is refused, loudly
                log.error("3D view: cannot unpack viser's client to allow its script (%s); the view stays empty",
                          exc)
    return tuple(hashes)


def content_security_policy(scripts: tuple[str, ...]) -> str:
    """Scripts: these inline ones and this server's files; everything else only from this server; no framing by
    any other page."""
    return "; ".join([
        "default-src 'self'",
        " ".join(["script-src 'self'", *scripts, "'unsafe-eval' 'wasm-unsafe-eval'"]),
        "style-src 'self' 'unsafe-inline'",
        "img-src 'self' data: blob:",
        "font-src 'self' data:",
        "worker-src blob:",
        "connect-src 'self' data:",  # data: only for a WebAssembly module viser bundles as a data URL
        "object-src 'none'",
        "base-uri 'none'",
        "form-action 'none'",
        "frame-ancestors 'self'",
    ])


class RobotShown(BaseModel):
    updates: int  # joint updates applied
    joints: list[str]


class Figure(BaseModel):
    """A robot figure in the scene, told apart from the others by its kind's colour and its name above it."""

    name: str  # the robot id, or "<robot>_preview" for the editor's preview ghost
    kind: str  # "live", "replay" or "preview"
    visible: bool
    color: str  # "#rrggbb" of its meshes; "" for the URDF's own colours (a live robot)


class Robot3dStatus(BaseModel):
    port: int | None  # viser's loopback port; None: the view is off
    viewers: int  # browsers showing the scene
    failed: dict[str, str]  # robots whose model did not load, with the reason
    robots: dict[str, RobotShown]
    figures: list[Figure] = []


class VisibleRequest(BaseModel):
    name: str
    visible: bool


def _view(state: ServerState) -> Robot3D:
    view = state.robot3d
    if view is None or view.server is None:
        raise HTTPException(404, "the 3D view is off (start the server with --robot3d)")
    return view


@router.get("/api/robot3d", response_model=Robot3dStatus)
def robot3d_status(state: ServerState = Depends(get_state)) -> dict[str, Any]:
    """Which robots the 3D view shows (joint updates applied) and which failed to load, with the reason; how many
    browsers show it; viser's loopback port."""
    view = state.robot3d
    return view.status() if view is not None else {"port": None, "viewers": 0, "failed": {}, "robots": {}}


@router.post("/api/robot3d/visible", dependencies=[Depends(require_token)], response_model=Robot3dStatus)
def show_figure(request: VisibleRequest, state: ServerState = Depends(get_state)) -> dict[str, Any]:
    """Shows or hides one robot figure (with its label) in the 3D view, for every page showing it. A name not in
    the scene now is remembered (a preview ghost hidden stays hidden when the next preview plays)."""
    view = _view(state)
    view.set_visible(request.name, request.visible)
    return view.status()


@router.get(PREFIX, include_in_schema=False)
def view_page_slash() -> RedirectResponse:
    return RedirectResponse(f"{PREFIX}/")


@router.get(PREFIX + "/{path:path}")
async def view_file(path: str, state: ServerState = Depends(get_state)) -> Response:
    """viser's client (its page, or any file viser serves), with a Content-Security-Policy fitting it."""
    view = _view(state)
    if not _PATH.match(path):
        raise HTTPException(404, f"no 3D view file {path!r}")
    try:
        async with httpx.AsyncClient(timeout=30.0) as client:
            upstream = await client.get(f"http://{LOOPBACK}:{view.port}/{path}")
    except httpx.HTTPError as exc:
        raise HTTPException(502, f"viser did not answer: {exc}") from exc
    body = upstream.content
    is_page = upstream.headers.get("content-type", "").startswith("text/html") and upstream.status_code == 200
    scripts = await asyncio.to_thread(page_script_hashes, upstream.text) if is_page else ()
    headers = {name: upstream.headers[name] for name in _PASSED_HEADERS if name in upstream.headers}
    headers.update({"Content-Security-Policy": content_security_policy(scripts), "X-Content-Type-Options": "nosniff",
                    "Cache-Control": "no-cache"})
    return Response(body, status_code=upstream.status_code, headers=headers)


@router.websocket(PREFIX)
@router.websocket(PREFIX + "/{path:path}")
async def view_socket(websocket: WebSocket, state: ServerState = Depends(get_state)) -> None:
    """The browser's viser WebSocket, bridged to viser's with the same subprotocol (viser's version check)."""
    from websockets.asyncio.client import connect
    from websockets.exceptions import WebSocketException
    from websockets.typing import Subprotocol

    view = state.robot3d
    if view is None or view.server is None:
        await websocket.close(1008, "the 3D view is off")
        return
    asked = [Subprotocol(p) for p in websocket.scope.get("subprotocols", [])]
    try:
        upstream = await connect(f"ws://{LOOPBACK}:{view.port}/", subprotocols=asked or None, compression=None,
                                 max_size=MAX_FRAME_BYTES, max_queue=QUEUED_FRAMES, open_timeout=10)
    except (OSError, TimeoutError, WebSocketException) as exc:
        log.warning("3D view: viser refused the WebSocket: %s", exc)
        await websocket.close(1011, "viser did not answer")
        return
    async with upstream:
        await websocket.accept(subprotocol=upstream.subprotocol)
        await _bridge(websocket, upstream)


async def _to_viser(websocket: WebSocket, upstream: Any) -> tuple[int, str]:
    """Browser -> viser until the browser closes; returns its close code and reason."""
    while True:
        message = await websocket.receive()
        if message["type"] == "websocket.disconnect":
            return int(message.get("code", 1000)), str(message.get("reason") or "")
        data = message.get("bytes")
        await upstream.send(data if data is not None else message.get("text", ""))


async def _to_browser(websocket: WebSocket, upstream: Any) -> None:
    """viser -> browser until viser closes; each send waits while the browser's socket is full."""
    async for data in upstream:
        if isinstance(data, bytes):
            await websocket.send_bytes(data)
        else:
            await websocket.send_text(data)


def _sendable(code: int | None) -> int:
    return 1000 if code is None or code in _UNSENDABLE_CLOSE_CODES else code


async def _bridge(websocket: WebSocket, upstream: Any) -> None:
    to_viser = asyncio.create_task(_to_viser(websocket, upstream))
    to_browser = asyncio.create_task(_to_browser(websocket, upstream))
    done, pending = await asyncio.wait({to_viser, to_browser}, return_when=asyncio.FIRST_COMPLETED)
    for task in pending:
        task.cancel()
    await asyncio.gather(*pending, return_exceptions=True)
    if to_viser in done and not to_viser.cancelled() and to_viser.exception() is None:
        code, reason = to_viser.result()  # the browser left: tell viser the same
        with contextlib.suppress(Exception):
            await upstream.close(_sendable(code), reason[:120])
        return
    # viser closed (or a side failed): the browser gets viser's code and reason
    with contextlib.suppress(Exception):
        await upstream.close()
    with contextlib.suppress(Exception):
        await websocket.close(_sendable(upstream.close_code), (upstream.close_reason or "")[:120])
