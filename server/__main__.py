"""``pitchside serve`` (also ``python -m server``): runs the dashboard and prints its URL (and the control token when
one is needed)."""

from __future__ import annotations

import argparse
import logging
import os
import re
import sys
from pathlib import Path

from server.config import RobotDescription, ServerConfig
from server.profiles.flags import add_ros2_arguments, ros2_setup
from server.security.credentials import ENV_TOKEN
from server.security.token_file import remove_token_file, write_token_file
from wire.bus import add_bus_arguments, bus_from_arguments
from wire.command_line import CommandParser
from wire.machine import machine_addresses
from wire.team_key import secured_bus, team_key_beside


def plots_memory(text: str) -> str:
    """A size rerun's --server-memory-limit takes: a number and a unit (B, KB, MB, GB, KiB, MiB, GiB)."""
    if not re.fullmatch(r"\d+(\.\d+)?\s*(B|KB|MB|GB|KiB|MiB|GiB)", text.strip()):
        raise argparse.ArgumentTypeError(f"{text!r}: a size such as 256MiB or 1GB")
    return text.strip().replace(" ", "")


def arguments(prog: str = "pitchside serve", description: str = "the pitchside dashboard server") -> CommandParser:
    """The server's options; ``pitchside replay`` takes the same ones (it runs this server)."""
    p = CommandParser(prog=prog, description=description)
    p.add_argument("--host", default="127.0.0.1",
                   help="bind address (default 127.0.0.1; beyond loopback, reading data needs the token too)")
    p.add_argument("--port", type=int, default=8080)
    p.add_argument("--allow-host", action="append", default=[], metavar="NAME",
                   help="another name the dashboard is reached by (Host header; loopback names and, beyond "
                        "loopback, this machine's addresses and names are always allowed)")
    p.add_argument("--allow-origin", action="append", default=[], metavar="URL",
                   help="another web origin (e.g. http://laptop2:8080) whose pages may use this server")
    p.add_argument("--allow-folder", action="append", default=[], metavar="DIR",
                   help="a folder replay may open logs from and the animation editor may edit in (besides "
                        "recordings/ and robots/)")
    p.add_argument("--match", action="store_true",
                   help="match mode: send nothing to robots (telemetry only, no Zenoh, control answers 403)")
    add_bus_arguments(p, connect_help="the team's Zenoh router (repeatable; default the one on this machine, "
                                      "tcp/127.0.0.1:7447); on another machine the server joins as a client")
    p.add_argument("--no-live", action="store_true", help="do not join the Zenoh network at start")
    add_ros2_arguments(p)
    p.add_argument("--no-telemetry", action="store_true", help="do not listen for UDP telemetry")
    p.add_argument("--telemetry-host", default="", metavar="ADDRESS",
                   help="the address telemetry is heard on: where the robots send from (default every interface; "
                        "on a secured team's lab dashboard, whose robots use the bus, 127.0.0.1)")
    p.add_argument("--telemetry-port", type=int, default=5800)
    p.add_argument("--gc-monitor", default=None, metavar="HOST",
                   help="register with the HSL GameController at HOST as a monitor and show the true game state and "
                        "every robot's status packet (robots gc<team>-<player>); off by default. Beside the "
                        "GameController, never on a robot: it refuses hosts that sent status packets")
    p.add_argument("--telemetry-key", default=None,
                   help="team telemetry key (a file made by `pitchside telemetry-key`, or hex; default: team.key "
                        "beside a secured team's --zenoh-config, else the published development key, which --match "
                        "and a secured team refuse)")
    p.add_argument("--allow-dev-key", action="store_true",
                   help="let --match run with the published development telemetry key (anyone can forge it)")
    p.add_argument("--token", default=None,
                   help=f"control token (default: ${ENV_TOKEN}, else a new random one); prefer the variable, "
                        "arguments are visible to other users of the machine")
    p.add_argument("--robot3d", action="store_true", help="serve the 3D robot view (viser)")
    p.add_argument("--robot3d-port", type=int, default=0,
                   help="viser's internal port on loopback (default 0: a free port browsers refuse to open)")
    p.add_argument("--urdf", action="append", default=[], metavar="[ROBOT=]PATH",
                   help="URDF of a robot (or of all robots without ROBOT=)")
    p.add_argument("--package", action="append", default=[], metavar="NAME=DIR",
                   help="folder that package://NAME/ points to (for the URDF's meshes)")
    p.add_argument("--plots", action="store_true", help="serve plots (rerun viewer)")
    p.add_argument("--plots-port", type=int, default=0, help="rerun's internal viewer port on loopback (0: as above)")
    p.add_argument("--plots-grpc-port", type=int, default=0,
                   help="rerun's internal gRPC port on loopback (0: as above), read through the dashboard")
    p.add_argument("--plots-max-hz", type=float, default=10.0,
                   help="numbers are plotted at most this often per stream (state lanes get every change)")
    p.add_argument("--plots-all-topics", action="store_true",
                   help="plot every numeric field of every topic (heavy on a small laptop; the panel adds topics "
                        "one by one)")
    p.add_argument("--plots-memory", type=plots_memory, default=os.environ.get("PITCHSIDE_PLOTS_MEMORY", "256MiB"),
                   help="the most plot history kept for viewers, e.g. 256MiB (the oldest goes first; default "
                        "$PITCHSIDE_PLOTS_MEMORY, else 256MiB)")
    p.add_argument("--foxglove-port", type=int, default=8765,
                   help="Foxglove WebSocket endpoint (a free one if taken), for Foxglove and Lichtblick, subprotocol "
                        "foxglove.sdk.v1 or foxglove.websocket.v1. Who may connect: with ?token=<token> in the URL "
                        "anyone, to watch and to control (parameters, services, publishing cmd_vel; lab only). "
                        "Without the token, only while --host is loopback and only to watch: clients sending no "
                        "Origin (scripts), the desktop apps (Origin file://), pages served on this machine "
                        "(http://localhost:*, http://127.0.0.1:*, a self-hosted Lichtblick) and --allow-origin "
                        "origins; Origin null and every other web page need the token")
    p.add_argument("--no-foxglove", action="store_true", help="no Foxglove WebSocket endpoint")
    p.add_argument("--foxglove-tls", default=None, metavar="CERT|TEAM_DIR",
                   help="serve the Foxglove endpoint as wss:// (for app.foxglove.dev or an https Lichtblick on "
                        "another machine): a PEM certificate (chain) file, or the team folder of `pitchside "
                        "team-keys` after `pitchside team-keys DIR --web-names NAME,ADDRESS`")
    p.add_argument("--foxglove-tls-key", default=None, metavar="KEY",
                   help="the private key of --foxglove-tls CERT (default: in the certificate file)")
    p.add_argument("--recordings", default=None, metavar="DIR", help="recordings folder (default: recordings/)")
    p.add_argument("--no-auto-record", action="store_true", help="do not record matches automatically")
    p.add_argument("--recorder", default=None, metavar="URL",
                   help="the recorder process beside this server (http://127.0.0.1:PORT, `python -m server.recording`; "
                        "its token in $PITCHSIDE_RECORDER_TOKEN): recordings go on when this server dies (default: "
                        "the recorder runs inside this server)")
    p.add_argument("--standby-lock", default=None, metavar="FILE",
                   help="run as one of two copies: the one holding FILE's lock serves, the other waits imported and "
                        "ready and serves as soon as the first dies (server.standby)")
    p.add_argument("--replay", default=None, metavar="FILE", help="open this MCAP log in the replay source")
    p.add_argument("--log-level", default="INFO")
    return p


def config_from(args: argparse.Namespace) -> ServerConfig:
    bus = bus_from_arguments(args)
    secured = False
    telemetry_key = args.telemetry_key
    if args.zenoh_config:
        try:
            secured = secured_bus(args.zenoh_config)  # said at start, not when the first panel opens the session
        except ValueError as exc:
            raise SystemExit(str(exc)) from None
        if secured and not telemetry_key:
            found = team_key_beside(args.zenoh_config)
            telemetry_key = str(found) if found else None
    ros2 = ros2_setup(args)
    packages = dict(ros2.profile.packages)
    for item in args.package:
        name, sep, folder = item.partition("=")
        if not sep:
            raise SystemExit(f"--package expects NAME=DIR, got {item!r}")
        packages[name] = Path(folder)
    descriptions = {}
    for item in args.urdf:
        robot, sep, path = item.partition("=")
        robot, path = (robot, path) if sep else ("*", robot)
        descriptions[robot] = RobotDescription(Path(path), packages)
    if packages and not descriptions:
        descriptions["*"] = RobotDescription(packages=packages)
    if args.foxglove_tls:  # said at start, not when the first app connects
        from server.foxglove.tls import TlsError, server_context

        try:
            server_context(Path(args.foxglove_tls), Path(args.foxglove_tls_key) if args.foxglove_tls_key else None)
        except TlsError as exc:
            raise SystemExit(str(exc)) from None
    try:
        return ServerConfig(match_mode=args.match, host=args.host, port=args.port, token=args.token, bus=bus,
                            allowed_hosts=args.allow_host, allowed_origins=args.allow_origin,
                            allowed_folders=[Path(f) for f in args.allow_folder], allow_dev_key=args.allow_dev_key,
                            live_source=False if (args.no_live or args.match) else None, ros2=ros2,
                            telemetry_source=not args.no_telemetry, telemetry_host=args.telemetry_host,
                            telemetry_port=args.telemetry_port, telemetry_key=telemetry_key,
                            gc_monitor=args.gc_monitor, robot3d=args.robot3d, secured_team=secured,
                            robot3d_port=args.robot3d_port, descriptions=descriptions, plots=args.plots,
                            plots_web_port=args.plots_port,
                            plots_grpc_port=args.plots_grpc_port, plots_max_hz=args.plots_max_hz,
                            plots_all_topics=args.plots_all_topics, plots_memory=args.plots_memory,
                            foxglove_port=None if args.no_foxglove else args.foxglove_port,
                            foxglove_tls=Path(args.foxglove_tls) if args.foxglove_tls else None,
                            foxglove_tls_key=Path(args.foxglove_tls_key) if args.foxglove_tls_key else None)
    except ValueError as exc:
        raise SystemExit(str(exc)) from None


def dashboard_url(config: ServerConfig) -> str:
    shown = "127.0.0.1" if config.host in ("0.0.0.0", "::") else config.host
    shown = f"[{shown}]" if ":" in shown else shown
    return f"http://{shown}:{config.port}/"


def reachable_urls(config: ServerConfig) -> list[str]:
    """Where browsers reach the dashboard: on every interface address when it listens on all of them."""
    if config.host not in ("0.0.0.0", "::"):
        return [dashboard_url(config)]
    addresses = sorted(a for a in machine_addresses() if ":" not in a and not a.startswith("127."))
    if config.host == "::":
        addresses += sorted(a for a in machine_addresses() if ":" in a and not a.startswith(("fe80", "::1")))
    return [dashboard_url(config)] + [f"http://{f'[{a}]' if ':' in a else a}:{config.port}/" for a in addresses]


def start_banner(config: ServerConfig) -> str:
    """The link carries the token: opening it signs the browser in (an HttpOnly cookie) and drops it from the URL.
    Listening on all interfaces, every address is printed: other machines need one of them."""
    urls = reachable_urls(config)
    lines = [f"pitchside dashboard: {urls[0]}?token={config.token}"]
    lines += [f"                     {url}?token={config.token}" for url in urls[1:]]
    if len(urls) == 1 and not config.beyond_loopback:
        lines.append("(this machine only; other machines need --host 0.0.0.0, or the address to listen on)")
    if config.match_mode:
        lines.append("MATCH MODE: telemetry only, nothing is sent to robots, control is off")
    if config.telemetry_source and (config.match_mode or config.secured_team):
        lines.append(f"telemetry key: {telemetry_key_name(config)}, heard on UDP {config.telemetry_host}:"
                     f"{config.telemetry_port}")
    lines.append(f"control token: {config.token}  (scripts: header 'Authorization: Bearer <token>'; "
                 "`pitchside record` on this machine finds it by itself)")
    if config.beyond_loopback:
        lines.append("listening beyond loopback: reading data needs the token too")
    return "\n".join(lines)


def telemetry_key_name(config: ServerConfig) -> str:
    from wire.telemetry.datagram import key_fingerprint, load_key

    name = key_fingerprint(load_key(config.telemetry_key))
    return "the published development key (anyone can forge it)" if name == "development" else f"team {name}"


def serve(argv: list[str] | None = None) -> None:
    run(arguments().parse_args(argv))


def run(args: argparse.Namespace) -> None:
    """Runs the dashboard with parsed options (of ``arguments``) until Ctrl-C or SIGTERM."""
    import uvicorn

    from server.app import create_app
    from wire.heap import freeze_startup_heap

    logging.basicConfig(level=args.log_level, format="%(asctime)s %(levelname)s [server] %(message)s")
    config = config_from(args)
    if args.recordings:
        config.recordings_dir = Path(args.recordings)
    config.auto_record_matches = not args.no_auto_record
    config.replay_file = Path(args.replay) if args.replay else None
    if args.recorder:
        from server.recording.service import RECORDER_TOKEN_ENV

        config.recorder_url, config.recorder_token = args.recorder, os.environ.get(RECORDER_TOKEN_ENV, "")
    app = create_app(config)
    freeze_startup_heap()  # the modules and the app: what each full collection would walk again
    if args.standby_lock:
        from server.standby import wait_to_serve

        # a spare that takes over serves first and starts the 3D view and plots (seconds) while it already serves
        config.views_in_background = wait_to_serve(Path(args.standby_lock))
    print(start_banner(config), flush=True)
    try:
        write_token_file(config.port, dashboard_url(config), config.token or "")
    except OSError as exc:
        logging.warning("token not left for the command line (%s): pass --token to `pitchside record`", exc)
    # an open browser holds endless streams (parameter events): on SIGTERM/Ctrl-C wait for them at most 2 s.
    # ws_max_size: a client frame larger than this is closed with 1009; smaller ones get an error frame.
    try:
        uvicorn.run(app, host=config.host, port=config.port, log_level=args.log_level.lower(), access_log=False,
                    timeout_graceful_shutdown=2, ws_max_size=1 << 20)
    finally:
        remove_token_file(config.port)


if __name__ == "__main__":
    serve(sys.argv[1:])
