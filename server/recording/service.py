"""The recorder as its own process: its own hub and sources, the Recorder, and a control API on loopback.

Beside the dashboard rather than inside it, so a crash or restart of the dashboard never touches a recording. It
hears what the dashboard hears by itself (telemetry from the supervisor's tap, wire.telemetry.tap; the live Zenoh
source outside match mode) and writes the same MCAP series as the in-process recorder did. The dashboard controls it
(start, stop, bookmark, status) over HTTP on 127.0.0.1 with a per-start bearer token (RECORDER_TOKEN_ENV, handed
over in the environment). It sends nothing to robots: allowed in match mode.

    python -m server.recording --control-port 5899 [the dashboard's source options: --telemetry-port, --match ...]
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import secrets
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from typing import Any

from fastapi import Depends, FastAPI, HTTPException, Request
from fastapi.responses import JSONResponse, Response
from pydantic import BaseModel

from server.config import ServerConfig
from server.hub import Hub
from server.recorder import Recorder, RecorderError
from server.security.credentials import new_token
from server.sources import SourceError, SourceSet
from server.sources.live import LiveZenohSource
from server.sources.telemetry import TelemetrySource
from server.zenoh_link import ZenohLink
from wire.machine import is_loopback

log = logging.getLogger(__name__)

RECORDER_TOKEN_ENV = "PITCHSIDE_RECORDER_TOKEN"
LOOPBACK_HOSTS = frozenset({"127.0.0.1", "localhost", "::1", "[::1]"})


class StartRequest(BaseModel):
    name: str = ""


class BookmarkRequest(BaseModel):
    name: str
    data: dict[str, Any] | None = None


def control_app(config: ServerConfig, token: str) -> FastAPI:
    """The recorder process's app: sources and recorder start with its lifespan; every route needs the token."""
    if not token:
        raise ValueError("the recorder's control token must not be empty")
    hub = Hub(config.queue_size)
    link = ZenohLink(config.bus, config.match_mode)
    sources = SourceSet([LiveZenohSource(hub, link),
                         TelemetrySource(hub, config.telemetry_host, config.telemetry_port, config.telemetry_key)])
    recorder = Recorder(hub, config.recordings_dir, auto_match=config.auto_record_matches,
                        description_for=config.description_for if config.descriptions else None)
    started = time.time()

    @asynccontextmanager
    async def lifespan(_app: FastAPI) -> AsyncIterator[None]:
        hub.bind(asyncio.get_running_loop())
        wanted = {"live": bool(config.live_source) and not config.match_mode, "telemetry": config.telemetry_source}
        for name, on in wanted.items():
            if on:
                try:
                    await sources.switch(name, True)
                except SourceError as exc:
                    log.warning("recorder: source %s not started: %s", name, exc)
        await recorder.start()
        try:
            yield
        finally:
            with contextlib.suppress(Exception):
                await recorder.close()
            await sources.stop_all()
            await asyncio.to_thread(link.close)

    def authorized(request: Request) -> None:
        scheme, _, value = request.headers.get("authorization", "").partition(" ")
        if scheme.lower() != "bearer" or not secrets_equal(value.strip(), token):
            raise HTTPException(401, "the recorder's control token is missing or wrong")

    app = FastAPI(title="pitchside recorder", lifespan=lifespan, docs_url=None, redoc_url=None, openapi_url=None)
    app.state.recorder = recorder

    @app.middleware("http")
    async def loopback_only(request: Request, call_next: Callable[[Request], Awaitable[Response]]) -> Response:
        host = request.headers.get("host", "").rsplit(":", 1)[0]
        client = request.client.host if request.client else ""
        if host not in LOOPBACK_HOSTS or not is_loopback(client):  # DNS rebinding, another machine
            return JSONResponse({"detail": "the recorder answers on loopback only"}, status_code=421)
        return await call_next(request)

    @app.exception_handler(RecorderError)
    async def refused(_request: Request, exc: RecorderError) -> JSONResponse:
        return JSONResponse({"detail": str(exc)}, status_code=409)

    @app.get("/status", dependencies=[Depends(authorized)])
    def status() -> dict[str, Any]:
        return {**recorder.status(), "pid": os.getpid(), "up_since": started,
                "active": sorted(recorder.active_paths())}

    @app.post("/start", dependencies=[Depends(authorized)])
    async def start(request: StartRequest | None = None) -> dict[str, Any]:
        return (await recorder.start_manual((request or StartRequest()).name)).as_dict()

    @app.post("/stop", dependencies=[Depends(authorized)])
    async def stop() -> dict[str, Any] | None:
        stopped = await recorder.stop_manual()
        return stopped.as_dict() if stopped is not None else None

    @app.post("/bookmark", dependencies=[Depends(authorized)])
    def bookmark(request: BookmarkRequest) -> dict[str, Any]:
        return {"recordings": recorder.bookmark(request.name, request.data)}

    return app


def secrets_equal(a: str, b: str) -> bool:
    return secrets.compare_digest(a.encode(), b.encode())


def token_from_environment() -> str:
    """The token the supervisor handed over; a fresh one (nobody can control it then) when none was."""
    return os.environ.get(RECORDER_TOKEN_ENV) or new_token()
