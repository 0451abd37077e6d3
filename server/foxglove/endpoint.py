"""The Foxglove WebSocket server (foxglove-sdk, subprotocol ``foxglove.sdk.v1``) the dashboard runs beside itself.

Clients connect to the guard (server.foxglove.guard), which listens where the dashboard listens (port 8765, or a
free one when it is taken) and asks for the dashboard's token as the dashboard does; the SDK itself listens on a
loopback port browsers refuse, reached only through the guard.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from typing import TYPE_CHECKING, Any

import foxglove

from server.foxglove.annotations import CameraAnnotations
from server.foxglove.channels import StreamChannels
from server.foxglove.guard import FoxgloveGuard, GuardPolicy
from server.foxglove.nodelay import NoDelayWatch
from server.loopback_ports import LOOPBACK, internal_port
from server.security.credentials import Credentials
from server.security.guard import normalized_origin
from server.security.hosts import AllowedHosts
from wire.machine import machine_addresses

if TYPE_CHECKING:
    from server.config import ServerConfig
    from server.state import ServerState

log = logging.getLogger(__name__)
DEFAULT_PORT = 8765  # what Foxglove's and Lichtblick's "Open connection" dialog proposes
SERVER_NAME = "pitchside"
# Per client: messages the SDK queues before it drops the oldest. At 11 robots' rates that is a fraction of a
# second, and with images a few MB at most, so a client that never reads costs bounded memory.
CLIENT_BACKLOG = 1024
NODELAY_PERIOD_S = 0.25  # how soon a new connection from the guard gets TCP_NODELAY (server.foxglove.nodelay)


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
    """Where Foxglove reaches the endpoint; beyond loopback with the token, which it then needs."""
    hosts = [config.host]
    if config.host in ("0.0.0.0", "::"):
        hosts = ["127.0.0.1", *sorted(a for a in machine_addresses() if ":" not in a and not a.startswith("127."))]
    query = f"/?token={config.token}" if config.beyond_loopback else ""
    return [f"ws://{f'[{h}]' if ':' in h else h}:{port}{query}" for h in hosts]


class FoxgloveEndpoint:
    """The SDK's server, its guard and what it serves; kept in ``state.foxglove``, stopped with the views."""

    def __init__(self, state: ServerState) -> None:
        self.state = state
        self.context = foxglove.Context()  # this endpoint's channels only, apart from any other SDK user
        self.channels = StreamChannels(state.hub, self.context, state.config.lost_after_s, self._source_running,
                                       derived=[CameraAnnotations(self.context)])
        self.server: Any = None  # foxglove.websocket.WebSocketServer once started
        self.guard = FoxgloveGuard(guard_policy(state.config), state.config.host, 0)
        self._nodelay: asyncio.Task[None] | None = None

    @property
    def port(self) -> int:
        return self.guard.port

    @property
    def urls(self) -> list[str]:
        return urls_of(self.state.config, self.port)

    async def start(self, preferred_port: int) -> None:
        """The SDK on a browser-refused loopback port, the guard on ``preferred_port`` or, when it is taken, any
        free port (0: any free port)."""
        sdk_port = internal_port(0, "Foxglove endpoint")
        self.server = await asyncio.to_thread(self._serve, sdk_port)
        self.guard.sdk_port = int(self.server.port)
        try:
            await asyncio.to_thread(self.guard.start, preferred_port)
        except OSError as exc:
            if not preferred_port:
                raise FoxgloveError(f"Foxglove endpoint not started on {self.guard.host}: {exc}") from None
            log.warning("foxglove: port %d is taken, using a free one", preferred_port)
            self.guard = FoxgloveGuard(self.guard.policy, self.guard.host, self.guard.sdk_port)
            await asyncio.to_thread(self.guard.start, 0)
        self.channels.start()
        self._nodelay = asyncio.get_running_loop().create_task(self._watch_nodelay(), name="foxglove nodelay")

    def _serve(self, port: int) -> Any:
        try:
            return foxglove.start_server(name=SERVER_NAME, host=LOOPBACK, port=port, context=self.context,
                                         capabilities=[], message_backlog_size=CLIENT_BACKLOG)
        except RuntimeError as exc:  # the SDK says FoxgloveError: Failed to bind port ...
            raise FoxgloveError(f"Foxglove endpoint not started on {LOOPBACK}:{port}: {exc}") from None

    async def _watch_nodelay(self) -> None:
        watch = NoDelayWatch(self.guard.sdk_port)
        while True:
            try:
                await asyncio.to_thread(watch.apply)
            except Exception as exc:  # /proc unreadable: slower delivery, nothing worse
                log.warning("foxglove: TCP_NODELAY not set on the SDK's connections: %r", exc)
                return
            await asyncio.sleep(NODELAY_PERIOD_S)

    async def stop(self) -> None:
        if self._nodelay is not None:
            self._nodelay.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._nodelay
        await asyncio.to_thread(self.guard.stop)
        await self.channels.stop()
        if self.server is not None:
            await asyncio.to_thread(self.server.stop)
            self.server = None

    def banner(self) -> str:
        urls = self.urls
        lines = [f"pitchside foxglove: {urls[0]}  (Foxglove or Lichtblick: Open connection -> Foxglove WebSocket)"]
        lines += [f"                    {url}" for url in urls[1:]]
        return "\n".join(lines)

    def status(self) -> dict[str, Any]:
        return {"urls": self.urls, "channels": len(self.channels.channels), "logged": self.channels.logged,
                "dropped": self.channels.dropped, "accepted": self.guard.counters.accepted,
                "refused": self.guard.counters.refused}

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
    endpoint = FoxgloveEndpoint(state)
    try:
        await endpoint.start(port)
    except (FoxgloveError, OSError) as exc:
        log.warning("%s", exc)
        await endpoint.stop()
        return None
    print(endpoint.banner(), flush=True)
    return endpoint
