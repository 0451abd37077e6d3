"""What the routers share (hub, config, sources, Zenoh link, the optional views), handed to them by dependency
injection."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from server.config import ServerConfig
from server.hub import Hub
from server.sources import SourceSet
from server.zenoh_link import ZenohLink

if TYPE_CHECKING:  # the views import viser and rerun: heavy, and only started when the config asks for them
    from server.foxglove.endpoint import FoxgloveEndpoint
    from server.lab import LabTools
    from server.node_graph import NodeGraph
    from server.plots import PlotFeed
    from server.recorder import Recorder
    from server.recording.remote import RemoteRecorder
    from server.robot3d import Robot3DView
    from server.sources.replay import ReplaySource


@dataclass(slots=True)
class ServerState:
    config: ServerConfig
    hub: Hub
    sources: SourceSet
    link: ZenohLink
    telemetry_key: str = ""  # what the page shows of the key: "development" or a team key's fingerprint
    recorder: Recorder | RemoteRecorder | None = None  # set by server.recording.wiring
    replay: ReplaySource | None = None
    robot3d: Robot3DView | None = None  # the 3D view (--robot3d), once started
    plots: PlotFeed | None = None  # the plots (--plots), once started
    foxglove: FoxgloveEndpoint | None = None  # the Foxglove endpoint (--foxglove-port), once started
    lab: LabTools | None = None  # what lives between lab requests, made on first use (server.lab.lab_tools)
    graph: NodeGraph | None = None  # the node graph from Zenoh liveliness (lab, live source on), once started
