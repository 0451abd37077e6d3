"""The dashboard server's configuration: one dataclass, built by the CLI or by tests."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import robots
import web
from server.profiles.team import Ros2Setup
from server.security.credentials import ENV_TOKEN, new_token
from wire.bus import BusConfig
from wire.machine import is_loopback

DEFAULT_URDF = robots.urdf()
WEB_DIR = web.ROOT


@dataclass(slots=True)
class RobotDescription:
    """Where the 3D view finds a robot's URDF and the folders its ``package://`` paths point to."""

    urdf: Path = DEFAULT_URDF
    packages: dict[str, Path] = field(default_factory=dict)


@dataclass(slots=True)
class ServerConfig:
    """Everything the server needs to know at start; tests build it directly.

    ``match_mode``: the server sends nothing to any robot. Then the live Zenoh source stays off (no Zenoh
    session is opened at all, since even a subscriber sends declarations), only the passive UDP telemetry
    listener runs, and every control endpoint answers 403.
    """

    match_mode: bool = False
    host: str = "127.0.0.1"
    port: int = 8080
    # the control credential; None: $PITCHSIDE_TOKEN, else a new random one per start. Needed on loopback too.
    token: str | None = None
    allowed_hosts: list[str] = field(default_factory=list)  # Host names besides loopback and this machine's own
    allowed_origins: list[str] = field(default_factory=list)  # web origins besides the dashboard's own page
    allowed_folders: list[Path] = field(default_factory=list)  # where replay may open logs, besides recordings
    max_body_bytes: int = 4 << 20
    bus: BusConfig = field(default_factory=BusConfig)
    live_source: bool | None = None  # None: on outside match mode, off in match mode
    # the ROS 2 domains the live source listens to, the team file's robots, the team profile, interface folder
    ros2: Ros2Setup = field(default_factory=Ros2Setup)
    telemetry_source: bool = True
    # where telemetry is heard: "" chooses by mode (every interface, except a secured team's lab dashboard, whose
    # robots talk over the bus: loopback)
    telemetry_host: str = ""
    telemetry_port: int = 5800  # wire.telemetry.datagram.DEFAULT_PORT
    telemetry_key: str | None = None  # team key (hex or a file); None: the development key
    # an HSL GameController to register with as a monitor (true game state, every robot's status); None: off
    gc_monitor: str | None = None
    gc_monitor_ports: tuple[int, int, int] = (3636, 3838, 3940)  # its request port; our true-state and status ports
    allow_dev_key: bool = False  # match mode with the published development key (refused unless set)
    secured_team: bool = False  # the bus is a secured team's (mutual TLS): never the development telemetry key
    queue_size: int = 2000  # frames per WebSocket client before the oldest are dropped
    stale_after_s: float = 1.5  # no message for this long: the robot (or stream) is shown stale
    lost_after_s: float = 5.0  # ... and lost
    robot3d: bool = False
    robot3d_port: int = 0  # viser's own port, loopback only (0: a port browsers refuse to open)
    robot3d_max_hz: float = 20.0
    descriptions: dict[str, RobotDescription] = field(default_factory=dict)  # robot id or "*" -> description
    plots: bool = False
    plots_web_port: int = 0  # rerun's viewer server, loopback only (0: as above)
    plots_grpc_port: int = 0  # rerun's gRPC server, loopback only (0: as above)
    plots_max_hz: float = 10.0
    plots_all_topics: bool = False  # also every numeric field of every topic, a tab per topic
    plots_memory: str = "256MiB"  # the most history rerun's server keeps for viewers (oldest dropped first)
    foxglove_port: int | None = None  # the Foxglove WebSocket endpoint (server.foxglove; 0: any port); None: off
    # wss:// instead of ws:// (server.foxglove.tls): a certificate file (its key beside it or in foxglove_tls_key),
    # or a team folder with the web.pem and web.key `pitchside team-keys --web-names` wrote
    foxglove_tls: Path | None = None
    foxglove_tls_key: Path | None = None
    web_dir: Path = WEB_DIR
    # where recordings go and replay looks for bare file names: recordings/ in the folder the server starts in
    # (the checkout's, for ./run demo); $PITCHSIDE_RECORDINGS or --recordings elsewhere
    recordings_dir: Path = field(default_factory=lambda: Path(os.environ.get("PITCHSIDE_RECORDINGS")
                                                              or Path.cwd() / "recordings"))
    auto_record_matches: bool = True  # record every match (per half) from the robots' gamestate
    replay_file: Path | None = None  # a log the replay source opens at start (pitchside replay FILE)
    # the recorder process beside this server (server.recording.service), http://127.0.0.1:PORT, and its token;
    # None: the recorder runs inside this server
    recorder_url: str | None = None
    recorder_token: str = ""
    # the 3D view and plots start after the server serves (a warm spare taking over, server.standby: the page and
    # the data first, within a second of the crash)
    views_in_background: bool = False

    def __post_init__(self) -> None:
        if self.live_source is None:
            self.live_source = not self.match_mode
        if self.match_mode and self.live_source:
            raise ValueError("match mode and the live Zenoh source exclude each other: in match mode the server "
                             "opens no Zenoh session (even a subscriber sends declarations to the robots)")
        if self.match_mode and not self.telemetry_key and not self.allow_dev_key:
            raise ValueError("match mode needs the team's telemetry key (--telemetry-key FILE, made by `pitchside "
                             "telemetry-key FILE`): with the published development key anyone at the venue can "
                             "forge your robots' data. Pass --allow-dev-key to run with it anyway")
        if self.secured_team and self.telemetry_source:
            self._check_team_key()
        if not self.telemetry_host:
            self.telemetry_host = "127.0.0.1" if self.secured_team and not self.match_mode else "0.0.0.0"
        if not self.token:
            self.token = os.environ.get(ENV_TOKEN) or new_token()

    def _check_team_key(self) -> None:
        """A secured team's telemetry takes its team key only: the development key is published, so anyone could
        forge robots past the bus's mutual TLS."""
        from wire.telemetry.datagram import DEV_KEY, load_key

        if self.allow_dev_key or not self.telemetry_key:
            raise ValueError("a secured team's dashboard needs the team's telemetry key: team.key beside the "
                             "team's Zenoh config (`pitchside team-keys` writes it) or --telemetry-key FILE; the "
                             "published development key is refused on a secured team (--allow-dev-key too). A "
                             "viewer, which holds no team key, reads the bus only: --no-telemetry")
        if load_key(self.telemetry_key) == DEV_KEY:
            raise ValueError("the telemetry key given is the published development key, refused on a secured team")

    @property
    def beyond_loopback(self) -> bool:
        """Reachable from other machines: then reading data needs the credential too, not only control."""
        return not is_loopback(self.host)

    @property
    def replay_folders(self) -> list[Path]:
        """Where replay opens logs: the recordings folder, folders given on the command line, --replay's folder."""
        folders = [self.recordings_dir, *self.allowed_folders]
        if self.replay_file is not None:
            folders.append(self.replay_file.expanduser().resolve().parent)
        return folders

    def description_for(self, robot: str) -> RobotDescription:
        return self.descriptions.get(robot) or self.descriptions.get("*") or RobotDescription()
