"""What the routers share (hub, config, sources, Zenoh link, the optional views), handed to them by dependency
injection."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

from server.config import ServerConfig
from server.hub import Hub
from server.sources import SourceSet
from server.zenoh_link import ZenohLink

if TYPE_CHECKING:
    from server.node_graph import NodeGraph
    from server.plots import PlotFeed
    from server.recorder import Recorder
    from server.recorder_remote import RemoteRecorder
    from server.sources.replay import ReplaySource


# The adapters (the Foxglove endpoint, the 3D view) and the lab's tools take the state, so the state names them only
# by what is asked of them here: no module imports another in a circle, not even for its types.
class Stoppable(Protocol):
    """Something the app stops with itself (app.py's lifespan)."""

    async def stop(self) -> None: ...


class StatusView(Stoppable, Protocol):
    """A view started when the config asks for it (the Foxglove endpoint: server/foxglove/endpoint.py)."""

    def status(self) -> dict[str, Any]: ...


class Robot3D(StatusView, Protocol):
    """The 3D view (server/robot3d.py) as its router and the lab use it: viser's server (None until started) on a
    loopback port."""

    @property
    def server(self) -> Any: ...

    @property
    def port(self) -> int | None: ...

    def set_visible(self, name: str, visible: bool) -> bool: ...


@dataclass(slots=True)
class ServerState:
    config: ServerConfig
    hub: Hub
    sources: SourceSet
    link: ZenohLink
    telemetry_key: str = ""  # what the page shows of the key: "development" or a team key's fingerprint
    recorder: Recorder | RemoteRecorder | None = None  # set by server.recording.wiring
    replay: ReplaySource | None = None
    robot3d: Robot3D | None = None  # the 3D view (--robot3d), once started
    plots: PlotFeed | None = None  # the plots (--plots), once started
    foxglove: StatusView | None = None  # the Foxglove endpoint (--foxglove-port), once started
    lab: Stoppable | None = None  # what lives between lab requests, made on first use (server.lab.lab_tools)
    graph: NodeGraph | None = None  # the node graph from Zenoh liveliness (lab, live source on), once started
