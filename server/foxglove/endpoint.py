"""The Foxglove WebSocket server (foxglove-sdk; foxglove.sdk.v1 and foxglove.websocket.v1) beside the dashboard.

Clients connect to the guard (server.foxglove.guard), which listens where the dashboard listens (port 8765, or a
free one when it is taken) and asks for the dashboard's token as the dashboard does; the SDK's servers
(server.foxglove.servers: one that shows, one that also offers control) listen on loopback ports browsers refuse,
reached only through the guard. This module puts the parts together and keeps them in step with the server: the
streams (channels), the 3D scene (scene), parameters, services and cmd_vel in the lab (parameters, services,
teleop), the node graph, and a replay's playback control (playback).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from typing import TYPE_CHECKING, Any

import foxglove
from foxglove.websocket import Capability

from server.config import RobotDescription
from server.foxglove.annotations import CameraAnnotations
from server.foxglove.assets import RobotAssets
from server.foxglove.channels import REPLAY_SOURCE, StreamChannels
from server.foxglove.guard import FoxgloveGuard, GuardPolicy, SdkPorts
from server.foxglove.listener import EndpointListener
from server.foxglove.nodelay import NoDelayWatch
from server.foxglove.parameters import RobotParameters
from server.foxglove.playback import SYNC_S, ReplayPlayback
from server.foxglove.scene import REPEAT_S, RobotScene
from server.foxglove.servers import Offer, SdkServers, ServerStartError
from server.foxglove.services import SERVED_BY, RobotServices, service_name
from server.foxglove.teleop import FoxgloveTeleop
from server.foxglove.tls import TlsError, server_context
from server.hub import HubMessage
from server.node_graph import service_providers, topic_links
from server.security.credentials import Credentials
from server.security.guard import normalized_origin
from server.security.hosts import AllowedHosts
from server.transforms import DEFAULT_MAX_HZ
from wire import keys
from wire.machine import machine_addresses

if TYPE_CHECKING:
    from server.config import ServerConfig
    from server.state import ServerState

log = logging.getLogger(__name__)
DEFAULT_PORT = 8765  # what Foxglove's and Lichtblick's "Open connection" dialog proposes
# after the guard passes a connection on, the SDK's side of it is looked for this long later (it accepts in its own
# time), until found: TCP_NODELAY (server.foxglove.nodelay) without looking at /proc while nobody connects
NODELAY_LOOKS_S = (0.0, 0.05, 0.2, 1.0, 3.0)
ROBOTS_PERIOD_S = 1.0  # how often the live robots (their services) are looked for
GRAPH_DEBOUNCE_S = 0.2  # a node's start declares a dozen tokens: one graph update for them
SUBSCRIBED_DELAY_S = 0.05
STOP_WAIT_S = 2.0


class FoxgloveError(RuntimeError):
    """The endpoint could not start (e.g. no port could be bound); the text says why."""


def guard_policy(config: ServerConfig) -> GuardPolicy:
    """The dashboard's rules (DESIGN.md section 11) for the Foxglove endpoint."""
    assert config.token, "ServerConfig always has a token after __post_init__"
    origins = frozenset(o for o in (normalized_origin(a) for a in config.allowed_origins) if o)
    return GuardPolicy(hosts=AllowedHosts(config.host, config.allowed_hosts),
                       credentials=Credentials(config.token, config.port), allowed_origins=origins,
                       token_needed=config.beyond_loopback)


def urls_of(config: ServerConfig, port: int) -> list[str]:
    """Where Foxglove reaches the endpoint (wss:// with --foxglove-tls); beyond loopback with the token, which it then
    needs."""
    hosts = [config.host]
    if config.host in ("0.0.0.0", "::"):
        hosts = ["127.0.0.1", *sorted(a for a in machine_addresses() if ":" not in a and not a.startswith("127."))]
    query = f"/?token={config.token}" if config.beyond_loopback else ""
    scheme = "wss" if config.foxglove_tls is not None else "ws"
    return [f"{scheme}://{f'[{h}]' if ':' in h else h}:{port}{query}" for h in hosts]


def shows_live(msg: HubMessage) -> bool:
    return msg.source != REPLAY_SOURCE


def shows_replay(msg: HubMessage) -> bool:
    return msg.source == REPLAY_SOURCE


class FoxgloveEndpoint:
    """The SDK's servers, their guard and what they serve; kept in ``state.foxglove``, stopped with the views."""

    def __init__(self, state: ServerState) -> None:
        self.state = state
        config = state.config
        self.lab = not config.match_mode
        self.context = foxglove.Context()  # this endpoint's channels only, apart from any other SDK user
        self.scene = RobotScene(self.context, self._description_for, self._now, DEFAULT_MAX_HZ)
        self.channels = StreamChannels(state.hub, self.context, config.lost_after_s, self._source_running,
                                       derived=[CameraAnnotations(self.context), self.scene])
        descriptions = [*config.descriptions.values(), RobotDescription()]
        self.assets = RobotAssets(descriptions)
        self.listeners = {door: EndpointListener(self._subscribed) for door in ("view", "control")}
        self.servers = SdkServers(self.context, self.listeners, self.assets)
        self.guard = FoxgloveGuard(guard_policy(config), config.host, SdkPorts())  # TLS: set in start
        self.services = RobotServices(state)
        self.parameters: RobotParameters | None = None
        self.playback: ReplayPlayback | None = None
        self.live_robots: frozenset[str] = frozenset()  # robots heard over Zenoh now: parameters, services
        self._served: set[tuple[str, str]] = set()  # (robot, service) the control server offers
        self._time_told = 0
        self._graph_due: asyncio.TimerHandle | None = None
        self._nodelay = NoDelayWatch(set())
        self._tasks: list[asyncio.Task[None]] = []
        self._loop: asyncio.AbstractEventLoop | None = None

    @property
    def port(self) -> int:
        return self.guard.port

    @property
    def urls(self) -> list[str]:
        return urls_of(self.state.config, self.port)

    # -- life -----------------------------------------------------------------------------------------------
    async def start(self, preferred_port: int) -> None:
        """The SDK's servers on browser-refused loopback ports, the guard on ``preferred_port`` or, when it is
        taken, any free port (0: any free port)."""
        loop = self._loop = asyncio.get_running_loop()
        control = self.listeners["control"]
        if self.state.replay is not None:
            self.playback = control.playback = ReplayPlayback(self.state.replay, loop)
        if self.lab:
            self.parameters = control.parameters = RobotParameters(self.state.link, lambda: self.live_robots,
                                                                   self._status)
            control.teleop = FoxgloveTeleop(self.state, loop, self._status)
        if self.state.config.foxglove_tls is not None:
            try:
                self.guard.tls = server_context(self.state.config.foxglove_tls, self.state.config.foxglove_tls_key)
            except TlsError as exc:
                raise FoxgloveError(str(exc)) from None
        offer = self._offer()
        await self._serve(offer)
        self.channels.shows = shows_replay if offer.replay else shows_live
        try:
            await asyncio.to_thread(self.guard.start, preferred_port)
        except OSError as exc:
            if not preferred_port:
                raise FoxgloveError(f"Foxglove endpoint not started on {self.guard.host}: {exc}") from None
            log.warning("foxglove: port %d is taken, using a free one", preferred_port)
            self.guard = FoxgloveGuard(self.guard.policy, self.guard.host, self.guard.sdk_ports, self.guard.tls)
            await asyncio.to_thread(self.guard.start, 0)
        self.channels.start()
        if self.parameters is not None and self.state.graph is not None:  # the server watches the bus (lab)
            try:
                await asyncio.to_thread(self.parameters.follow, self._publish_parameters)
            except Exception as exc:  # no bus: parameters are read when asked
                log.warning("foxglove: parameter changes not followed: %s", exc)
        if self.state.graph is not None:
            self.state.graph.on_change(self._graph_changed_elsewhere)
        for work, name in ((self._watch_nodelay, "nodelay"), (self._keep_in_step, "in step")):
            self._tasks.append(loop.create_task(work(), name=f"foxglove {name}"))

    async def _serve(self, offer: Offer) -> None:
        """(Re)starts the SDK's servers for ``offer``; the guard passes new connections to them at once."""
        try:
            await asyncio.to_thread(self.servers.start, offer)
        except ServerStartError as exc:
            raise FoxgloveError(str(exc)) from None
        ports = self.guard.sdk_ports = self.servers.ports
        self._nodelay.ports = {ports.view, ports.control}
        self._served.clear()
        self._time_told = 0
        if self.playback is not None:
            self.playback.forget_told()
        self._publish_graph()

    def _offer(self) -> Offer:
        replay = self.playback.time_range() if self.playback is not None else None
        return Offer(lab=self.lab, graph=self.state.graph is not None, replay=replay)

    async def stop(self) -> None:
        for task in self._tasks:
            task.cancel()
        if self._tasks:  # bounded: a task that lost its cancellation must not hold the server's shutdown
            await asyncio.wait(self._tasks, timeout=STOP_WAIT_S)
        if self._graph_due is not None:
            self._graph_due.cancel()
        await asyncio.to_thread(self.guard.stop)
        await self.channels.stop()
        if self.parameters is not None:
            await asyncio.to_thread(self.parameters.stop)
        await asyncio.to_thread(self.servers.stop)

    # -- in step with the server ----------------------------------------------------------------------------
    async def _keep_in_step(self) -> None:
        """Replay opened or closed (the servers start again with the log's time range), the replay's state and time
        (Foxglove's playback bar), the live robots' services, the latched URDFs and fixed joints."""
        next_robots = next_repeat = 0.0
        while True:
            await asyncio.sleep(SYNC_S)
            try:
                offer = self._offer()
                if offer != self.servers.offer:
                    log.info("foxglove: serving %s", "the replayed log" if offer.replay else "live robots")
                    await self._serve(offer)
                    self.channels.reset(shows_replay if offer.replay else shows_live)
                if offer.replay:
                    self._replay_in_step()
                now = time.monotonic()
                if now >= next_robots:
                    next_robots = now + ROBOTS_PERIOD_S
                    self._live_robots_in_step()
                if now >= next_repeat:
                    next_repeat = now + REPEAT_S
                    self.scene.republish()
            except FoxgloveError as exc:  # servers that could not start again: said, and tried again
                log.warning("%s", exc)
            except Exception:  # one bad turn must not end the endpoint's bookkeeping
                log.exception("foxglove: keeping in step failed")

    def _replay_in_step(self) -> None:
        assert self.playback is not None and self.state.replay is not None
        state = self.playback.changes()
        position = int(self.state.replay.position_ns)
        for door, server in self.servers.servers.items():
            if state is not None and door == "control":
                server.broadcast_playback_state(state)
            if position != self._time_told:
                server.broadcast_time(position)
        self._time_told = position

    def _live_robots_in_step(self) -> None:
        """The robots heard over Zenoh and not lost: their parameters are listed, their services offered (those its
        nodes serve, when the node graph tells; else both)."""
        if not self.lab:
            return
        now = time.monotonic()
        live = frozenset(
            robot for robot, seen in self.state.hub.robots.items()
            if not keys.is_replayed(robot) and now - seen.last_received < self.state.config.lost_after_s
            and any(stats.source == "live" for stats in seen.streams.values()))
        self.live_robots = live
        control = self.servers.servers.get("control")
        if control is None or not self.servers.has("control", Capability.Services):
            return
        graph = self.state.graph
        provided = set(service_providers(graph.snapshot())) if graph is not None else None
        wanted = {(robot, name) for robot in live for name, served_by in SERVED_BY.items()
                  if provided is None or f"/{robot}/{served_by}" in provided}
        gone = self._served - wanted
        if gone:
            control.remove_services([service_name(robot, name) for robot, name in sorted(gone)])
            self._served -= gone
        new = sorted(wanted - self._served)
        if new:
            control.add_services([self.services.service(robot, name) for robot, name in new])
            self._served |= set(new)

    # -- the node graph -----------------------------------------------------------------------------------
    def _graph_changed_elsewhere(self) -> None:
        """A Zenoh thread: the node graph changed."""
        if self._loop is not None:
            with contextlib.suppress(RuntimeError):  # the loop closed with the server
                self._loop.call_soon_threadsafe(self._graph_changed)

    def _graph_changed(self) -> None:
        if self._graph_due is None and self._loop is not None:
            self._graph_due = self._loop.call_later(GRAPH_DEBOUNCE_S, self._publish_graph)

    def _publish_graph(self) -> None:
        self._graph_due = None
        graph = self.state.graph
        if graph is None:
            return
        entries = graph.snapshot()
        update = foxglove.ConnectionGraph()
        for topic, links in topic_links(entries).items():
            if links.publishers:
                update.set_published_topic(topic, sorted(links.publishers))
            if links.subscribers:
                update.set_subscribed_topic(topic, sorted(links.subscribers))
        for service, providers in service_providers(entries).items():
            update.set_advertised_service(service, sorted(providers))
        for door, server in self.servers.servers.items():
            if self.servers.has(door, Capability.ConnectionGraph):
                server.publish_connection_graph(update)

    # -- callbacks --------------------------------------------------------------------------------------------
    def _subscribed(self, topic: str) -> None:
        """SDK thread: a client subscribed to ``topic``; the URDF and fixed joints go out at once, on the loop."""
        if self.scene.wants_repeat(topic) and self._loop is not None:
            with contextlib.suppress(RuntimeError):  # the loop closed with the server
                # the SDK counts the subscription only after this callback: send a moment later
                self._loop.call_soon_threadsafe(self._republish_soon)

    def _republish_soon(self) -> None:
        if self._loop is not None:
            self._loop.call_later(SUBSCRIBED_DELAY_S, self.scene.republish, None)

    def _status(self, message: str) -> None:
        """Tells the control server's clients why something they asked for was not done."""
        server = self.servers.servers.get("control")
        if server is not None:
            server.publish_status(message, foxglove.StatusLevel.Warning)

    def _publish_parameters(self, parameters: list[foxglove.Parameter]) -> None:
        server = self.servers.servers.get("control")
        if server is not None:
            server.publish_parameter_values(parameters)

    def _description_for(self, robot: str) -> RobotDescription:
        return self.state.config.description_for(robot)

    def _now(self) -> float:
        """The endpoint's clock: the log's time during a replay, else the wall clock."""
        replay = self.state.replay
        if self.servers.offer is not None and self.servers.offer.replay and replay is not None:
            return replay.position_ns / 1e9
        return time.time()

    async def _watch_nodelay(self) -> None:
        passed = asyncio.Event()
        loop = asyncio.get_running_loop()

        def on_pass() -> None:  # on the guard's thread
            loop.call_soon_threadsafe(passed.set)

        self.guard.on_pass = on_pass
        while True:
            await passed.wait()
            passed.clear()
            for delay in NODELAY_LOOKS_S:
                await asyncio.sleep(delay)
                try:
                    if await asyncio.to_thread(self._nodelay.apply):
                        break
                except Exception as exc:  # /proc unreadable: slower delivery, nothing worse
                    log.warning("foxglove: TCP_NODELAY not set on the SDK's connections: %r", exc)
                    return

    def banner(self) -> str:
        urls = self.urls
        lines = [f"pitchside foxglove: {urls[0]}  (Foxglove or Lichtblick: Open connection -> Foxglove WebSocket)"]
        lines += [f"                    {url}" for url in urls[1:]]
        controls = self.lab or self.playback is not None  # match mode: only a replay's playback bar
        if controls and not self.state.config.beyond_loopback:  # beyond loopback every URL carries the token already
            what = "parameters, services, cmd_vel" if self.lab else "the replay's playback"
            lines.append(f"  to control ({what}): {urls[0]}/?token={self.state.config.token}  (apps keep this URL "
                         "in their recent connections)")
        return "\n".join(lines)

    def status(self) -> dict[str, Any]:
        offer = self.servers.offer
        return {"urls": self.urls, "channels": len(self.channels.channels), "logged": self.channels.logged,
                "dropped": self.channels.dropped, "accepted": self.guard.counters.accepted,
                "with_token": self.guard.counters.with_token, "websocket_v1": self.guard.counters.websocket_v1,
                "refused": self.guard.counters.refused, "tls": self.guard.tls is not None,
                "serving": "replay" if offer is not None and offer.replay else "live",
                "scene_robots": sorted(self.scene.robots), "assets_served": self.assets.served,
                "assets_refused": self.assets.refused}

    def _source_running(self, name: str) -> bool | None:
        """Is the source a stream came from still on? None: not a source this server switches."""
        if name in self.state.sources.sources:
            return self.state.sources.sources[name].running
        replay = self.state.replay
        if replay is not None and name == replay.name:
            return bool(replay.running)
        return None


async def start_foxglove(state: ServerState) -> FoxgloveEndpoint | None:
    """Starts the endpoint the config asks for (``foxglove_port`` None: off) and prints where it listens; the app
    keeps it in ``state.foxglove`` and stops it with the views. A failure is logged, never fatal for the dashboard."""
    port = state.config.foxglove_port
    if port is None:
        return None
    if port == state.config.port:  # `--port 8765`: the dashboard's port counts as taken, the endpoint finds another
        port = 0
    endpoint = FoxgloveEndpoint(state)
    try:
        await endpoint.start(port)
    except (FoxgloveError, OSError) as exc:
        log.warning("%s", exc)
        await endpoint.stop()
        return None
    print(endpoint.banner(), flush=True)
    return endpoint
