"""create_app(config): the dashboard's FastAPI app with its hub, sources, routers and the static web page."""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI
from fastapi.staticfiles import StaticFiles

from server.config import ServerConfig
from server.foxglove import start_foxglove
from server.http_errors import install_error_statuses
from server.hub import Hub
from server.recording.wiring import attach_recording
from server.routers import (
    animations,
    dashboard,
    foxglove,
    graph,
    message_schemas,
    parameters,
    plots,
    recordings,
    replay,
    robot3d,
    robots,
    ros2,
    session,
    sources,
    state_graphs,
    teleop,
    ws,
)
from server.security import AllowedHosts, Credentials, VenueGuard, VenuePolicy
from server.security.guard import normalized_origin
from server.sources import Source, SourceError, SourceSet
from server.sources.gc_monitor import GameControllerMonitorSource
from server.sources.live import LiveZenohSource
from server.sources.telemetry import TelemetrySource
from server.state import ServerState
from server.zenoh_link import ZenohLink
from wire.telemetry.datagram import key_fingerprint, load_key

log = logging.getLogger(__name__)


def create_app(config: ServerConfig) -> FastAPI:
    """The app; sources, the 3D view and plots start with the app's lifespan (uvicorn or TestClient)."""
    hub = Hub(config.queue_size)
    link = ZenohLink(config.bus, config.match_mode)
    feeds: list[Source] = [
        LiveZenohSource(hub, link, config.ros2),
        TelemetrySource(hub, config.telemetry_host, config.telemetry_port, config.telemetry_key),
    ]
    if config.gc_monitor:  # asks the GameController, never a robot: allowed in match mode too
        request_port, data_port, forward_port = config.gc_monitor_ports
        feeds.append(GameControllerMonitorSource(hub, config.gc_monitor, request_port, data_port=data_port,
                                                 forward_port=forward_port))
    source_set = SourceSet(feeds)
    state = ServerState(config, hub, source_set, link, telemetry_key=key_fingerprint(load_key(config.telemetry_key)))

    @asynccontextmanager
    async def lifespan(_app: FastAPI) -> AsyncIterator[None]:
        hub.bind(asyncio.get_running_loop())
        wanted = {"live": bool(config.live_source) and not config.match_mode, "telemetry": config.telemetry_source,
                  "gc_monitor": bool(config.gc_monitor)}
        for name, on in wanted.items():
            if on and name in source_set.sources:
                try:
                    await source_set.switch(name, True)
                except SourceError as exc:
                    log.warning("source %s not started: %s", name, exc)
        views = None
        await recording.start()
        if config.views_in_background:  # a spare taking over: the page and its data first, the rest once it serves
            views = asyncio.get_running_loop().create_task(_start_the_rest_later(state))
        else:
            await _start_views(state)
            await _start_graph(state)
            state.foxglove = await start_foxglove(state)
        try:
            yield
        finally:
            if views is not None and not views.done():
                views.cancel()
            with contextlib.suppress(Exception):
                await recording.stop()
            await _stop_views(state)
            if state.graph is not None:
                await asyncio.to_thread(state.graph.stop)
            await source_set.stop_all()
            await asyncio.to_thread(link.close)

    # no /docs or /redoc: their pages load scripts from a CDN (offline, and against the page's CSP)
    app = FastAPI(title="pitchside dashboard", lifespan=lifespan, docs_url=None, redoc_url=None)
    app.state.pitchside = state
    app.add_middleware(VenueGuard, policy=venue_policy(config))
    recording = attach_recording(state)
    install_error_statuses(app)
    for module in (recordings, replay, session, dashboard, robots, message_schemas, sources, parameters, animations,
                   teleop, ws, plots, robot3d, state_graphs, graph, foxglove, ros2):
        app.include_router(module.router)
    app.mount("/", StaticFiles(directory=config.web_dir, html=True), name="web")
    return app


def venue_policy(config: ServerConfig) -> VenuePolicy:
    """What the VenueGuard lets through, from the server's configuration (DESIGN.md section 11)."""
    assert config.token, "ServerConfig always has a token after __post_init__"
    origins = set()
    for origin in config.allowed_origins:
        normal = normalized_origin(origin)
        if normal is None:
            raise ValueError(f"--allow-origin {origin!r} is not an origin like http://laptop:8080")
        origins.add(normal)
    return VenuePolicy(hosts=AllowedHosts(config.host, config.allowed_hosts),
                       credentials=Credentials(config.token, config.port), allowed_origins=frozenset(origins),
                       reads_need_credential=config.beyond_loopback, max_body_bytes=config.max_body_bytes)


# a spare that takes over starts the 3D view, the plots, the node graph and the Foxglove endpoint this long after its
# lifespan (uvicorn binds the port right after it): they block the loop for seconds on a busy machine
THE_REST_AFTER_S = 1.0


async def _start_the_rest_later(state: ServerState) -> None:
    await asyncio.sleep(THE_REST_AFTER_S)
    await _start_views(state)
    await _start_graph(state)
    state.foxglove = await start_foxglove(state)


async def _start_graph(state: ServerState) -> None:
    """The node graph (server.node_graph) while the server watches the bus: lab mode with the live source on."""
    config = state.config
    if config.match_mode or not config.live_source:
        return
    from server.node_graph import NodeGraph

    node_graph = NodeGraph(state.link)
    try:
        await asyncio.to_thread(node_graph.start)
        state.graph = node_graph
    except Exception as exc:  # no bus: the dashboard works without the graph
        log.warning("node graph not started: %s", exc)


async def _start_views(state: ServerState) -> None:
    """The optional 3D robot (viser) and plots (rerun): heavy, so off unless the config asks for them."""
    config = state.config
    if config.robot3d:
        from server.robot3d import Robot3DView

        view = Robot3DView(state.hub, config)
        try:
            await view.start()
            state.robot3d = view
        except Exception as exc:  # a broken URDF must not take the dashboard down
            log.warning("3D robot view not started: %s", exc)
    if config.plots:
        from server.plots import PlotFeed

        feed = PlotFeed(state.hub, config)
        try:
            await feed.start()
            state.plots = feed
        except Exception as exc:
            log.warning("plots not started: %s", exc)


async def _stop_views(state: ServerState) -> None:
    """The 3D view, the plots, then the lab's loops (they send a last zero command and cancel goals)."""
    for view in (state.foxglove, state.robot3d, state.plots, state.lab):
        if view is not None:
            with contextlib.suppress(Exception):
                await view.stop()
