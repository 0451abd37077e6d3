"""GET /plots/viewer/...: rerun's web viewer, passed through from its local server with a Content-Security-Policy.

rerun's viewer page links Google Fonts, and its wasm asks tel.rerun.io (usage analytics), api.github.com (newest
release) and app.rerun.io (examples). Offline these fail with console noise; at a venue with internet they would
leave the team's laptop. Served through here, the browser itself refuses every request that is not to this
server or to the viewer's own gRPC stream, and the font links are dropped from the page. Same origin as the
dashboard, too, so the panel embeds it without cross-origin rules.

The viewer's files change only with the rerun-sdk version: each carries an ETag of that version, and a browser
that has the file already gets 304 at once instead of another 43 MB of wasm read through the proxy.
"""

from __future__ import annotations

import re
from functools import cache
from importlib.metadata import version
from typing import Any

import httpx
from fastapi import APIRouter, Depends, HTTPException, Request
from fastapi.responses import Response

from server.deps import get_state
from server.state import ServerState

router = APIRouter(prefix="/plots/viewer", tags=["plots"])

_PATH = re.compile(r"^[A-Za-z0-9_.-]*$")  # the viewer's files sit in one flat folder
_FONT_LINKS = re.compile(r"<link\b[^>]*https://fonts\.(?:googleapis|gstatic)\.com[^>]*>", re.S)
_PASSED_HEADERS = ("content-type",)


@cache
def _etag(path: str) -> str:
    return f'"rerun-{version("rerun-sdk")}-{path or "index.html"}"'


def content_security_policy(host: str, grpc_port: int) -> str:
    """Everything from this server; data only from here and the viewer's gRPC stream; nothing from elsewhere."""
    grpc = f"http://{host}:{grpc_port}"
    return "; ".join([
        "default-src 'self'",
        "script-src 'self' 'unsafe-inline' 'unsafe-eval' 'wasm-unsafe-eval'",  # the page's inline loader, wasm
        "style-src 'self' 'unsafe-inline'",
        "img-src 'self' data: blob:",
        "font-src 'self' data:",
        "worker-src 'self' blob:",
        f"connect-src 'self' {grpc} data: blob:",
        "frame-ancestors 'self'",
    ])


@router.get("/{path:path}")
async def viewer_file(path: str, request: Request, state: ServerState = Depends(get_state)) -> Response:
    plots: Any = state.views.get("plots")
    if plots is None:
        raise HTTPException(404, "plots are off (start the server with --plots)")
    if not _PATH.match(path):
        raise HTTPException(404, f"no viewer file {path!r}")
    ports = plots.urls()
    policy = content_security_policy(request.url.hostname or "127.0.0.1", ports["grpc_port"])
    cached = {"ETag": _etag(path), "Cache-Control": "no-cache", "Content-Security-Policy": policy}
    if request.headers.get("if-none-match") == cached["ETag"]:
        return Response(status_code=304, headers=cached)
    url = f"http://127.0.0.1:{ports['web_port']}/{path}"
    try:
        async with httpx.AsyncClient(timeout=30.0) as client:
            upstream = await client.get(url)
    except httpx.HTTPError as exc:
        raise HTTPException(502, f"rerun's viewer server did not answer: {exc}") from exc
    body = upstream.content
    if path in ("", "index.html") and upstream.status_code == 200:
        body = _FONT_LINKS.sub("", upstream.text).encode()
    headers = {name: upstream.headers[name] for name in _PASSED_HEADERS if name in upstream.headers}
    headers.update(cached if upstream.status_code == 200 else {"Content-Security-Policy": policy})
    return Response(body, status_code=upstream.status_code, headers=headers)
