"""The Foxglove WebSocket server (foxglove-sdk, subprotocol ``foxglove.sdk.v1``) the dashboard runs beside itself.

It listens where the dashboard listens, but only on loopback: foxglove-sdk 0.30 offers no hook to look at a
client before it connects (no token, no Origin check), so beyond loopback it could not ask for the dashboard's
token. A dashboard started with ``--host 0.0.0.0`` keeps the endpoint on 127.0.0.1 and says so; another machine
reaches it through an SSH tunnel (``ssh -L 8765:127.0.0.1:8765 laptop``).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from typing import TYPE_CHECKING, Any

import foxglove

from server.foxglove.annotations import CameraAnnotations
from server.foxglove.channels import StreamChannels
from server.foxglove.nodelay import NoDelayWatch
from wire.machine import is_loopback

if TYPE_CHECKING:
    from server.state import ServerState

log = logging.getLogger(__name__)
DEFAULT_PORT = 8765  # what Foxglove's and Lichtblick's "Open connection" dialog proposes
LOOPBACK = "127.0.0.1"
SERVER_NAME = "pitchside"
# Per client: messages the SDK queues before it drops the oldest. At 11 robots' rates that is a fraction of a
# second, and with images a few MB at most, so a client that never reads costs bounded memory.
CLIENT_BACKLOG = 1024
NODELAY_PERIOD_S = 0.25  # how soon a new client's connection gets TCP_NODELAY (server.foxglove.nodelay)


class FoxgloveError(RuntimeError):
    """The endpoint could not start (e.g. no port could be bound); the text says why."""


def endpoint_host(dashboard_host: str) -> str:
    """Where the endpoint listens: the dashboard's host when that is loopback, else 127.0.0.1 (see module doc)."""
    return dashboard_host if is_loopback(dashboard_host) else LOOPBACK


def url_of(host: str, port: int) -> str:
    shown = "127.0.0.1" if host == "localhost" else host
    return f"ws://[{shown}]:{port}" if ":" in shown else f"ws://{shown}:{port}"


class FoxgloveEndpoint:
    """The SDK's server and what it serves; kept in ``state.views["foxglove"]`` and stopped with the views."""

    def __init__(self, state: ServerState) -> None:
        self.state = state
        self.host = endpoint_host(state.config.host)
        self.context = foxglove.Context()  # this endpoint's channels only, apart from any other SDK user
        self.channels = StreamChannels(state.hub, self.context, state.config.lost_after_s, self._source_running,
                                       derived=[CameraAnnotations(self.context)])
        self.server: Any = None  # foxglove.websocket.WebSocketServer once started
        self.port = 0
        self._nodelay: asyncio.Task[None] | None = None

    @property
    def url(self) -> str:
        return url_of(self.host, self.port)

    async def start(self, preferred_port: int) -> None:
        """Binds ``preferred_port``, or any free port when it is taken (0: any free port)."""
        try:
            self.server = await asyncio.to_thread(self._serve, preferred_port)
        except FoxgloveError:
            if not preferred_port:
                raise
            log.warning("foxglove: port %d is taken, using a free one", preferred_port)
            self.server = await asyncio.to_thread(self._serve, 0)
        self.port = int(self.server.port)
        self.channels.start()
        self._nodelay = asyncio.get_running_loop().create_task(self._watch_nodelay(), name="foxglove nodelay")

    async def _watch_nodelay(self) -> None:
        watch = NoDelayWatch(self.port)
        while True:
            try:
                await asyncio.to_thread(watch.apply)
            except Exception as exc:  # psutil cannot read /proc: slower delivery, nothing worse
                log.warning("foxglove: TCP_NODELAY not set on clients' connections: %r", exc)
                return
            await asyncio.sleep(NODELAY_PERIOD_S)

    def _serve(self, port: int) -> Any:
        try:
            return foxglove.start_server(name=SERVER_NAME, host=self.host, port=port, context=self.context,
                                         capabilities=[], message_backlog_size=CLIENT_BACKLOG)
        except RuntimeError as exc:  # the SDK says FoxgloveError: Failed to bind port ...
            raise FoxgloveError(f"Foxglove endpoint not started on {self.host}:{port}: {exc}") from None

    async def stop(self) -> None:
        if self._nodelay is not None:
            self._nodelay.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._nodelay
        await self.channels.stop()
        if self.server is not None:
            await asyncio.to_thread(self.server.stop)
            self.server = None

    def banner(self) -> str:
        lines = [f"pitchside foxglove: {self.url}  (Foxglove or Lichtblick: Open connection -> Foxglove WebSocket)"]
        if not is_loopback(self.state.config.host):
            lines.append("  the Foxglove endpoint stays on this machine (it cannot ask for the token); from another "
                         f"machine: ssh -L {self.port}:127.0.0.1:{self.port} <this machine>")
        return "\n".join(lines)

    def status(self) -> dict[str, Any]:
        return {"url": self.url, "channels": len(self.channels.channels), "logged": self.channels.logged,
                "dropped": self.channels.dropped}

    def _source_running(self, name: str) -> bool | None:
        """Is the source a stream came from still on? None: not a source this server switches."""
        if name in self.state.sources.sources:
            return self.state.sources.sources[name].running
        recording = self.state.views.get("recording")
        replay = getattr(recording, "replay", None)
        if replay is not None and name == replay.name:
            return bool(replay.running)
        return None


async def start_foxglove(state: ServerState) -> FoxgloveEndpoint | None:
    """Starts the endpoint the config asks for (``foxglove_port`` None: off), prints where it listens, and keeps
    it in ``state.views`` so the app's lifespan stops it. A failure is logged, never fatal for the dashboard."""
    port = state.config.foxglove_port
    if port is None:
        return None
    endpoint = FoxgloveEndpoint(state)
    try:
        await endpoint.start(port)
    except FoxgloveError as exc:
        log.warning("%s", exc)
        await endpoint.stop()
        return None
    state.views["foxglove"] = endpoint
    print(endpoint.banner(), flush=True)
    return endpoint
