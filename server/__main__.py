"""``python -m server``: runs the dashboard and prints its URL (and the control token when one is needed)."""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from robot_nodes.runtime.bus import BusConfig, load_config_file
from server.config import RobotDescription, ServerConfig


def arguments() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m server", description="pitchside dashboard server")
    p.add_argument("--host", default="127.0.0.1", help="bind address (default 127.0.0.1; others need a token)")
    p.add_argument("--port", type=int, default=8080)
    p.add_argument("--match", action="store_true",
                   help="match mode: send nothing to robots (telemetry only, no Zenoh, control answers 403)")
    p.add_argument("--connect", action="append", default=None, help="Zenoh endpoint of the team (repeatable)")
    p.add_argument("--zenoh-config", default=None, metavar="FILE",
                   help="a Zenoh JSON5 config file, e.g. the laptop's file from `pitchside team-keys` (overrides "
                        "--connect)")
    p.add_argument("--no-live", action="store_true", help="do not join the Zenoh network at start")
    p.add_argument("--no-telemetry", action="store_true", help="do not listen for UDP telemetry")
    p.add_argument("--telemetry-host", default="0.0.0.0")
    p.add_argument("--telemetry-port", type=int, default=5800)
    p.add_argument("--telemetry-key", default=None, help="team telemetry key (hex or a file; default: dev key)")
    p.add_argument("--token", default=None, help="control token (default: random, printed, when not on loopback)")
    p.add_argument("--robot3d", action="store_true", help="serve the 3D robot view (viser)")
    p.add_argument("--robot3d-port", type=int, default=8081)
    p.add_argument("--urdf", action="append", default=[], metavar="[ROBOT=]PATH",
                   help="URDF of a robot (or of all robots without ROBOT=)")
    p.add_argument("--package", action="append", default=[], metavar="NAME=DIR",
                   help="folder that package://NAME/ points to (for the URDF's meshes)")
    p.add_argument("--plots", action="store_true", help="serve plots (rerun viewer)")
    p.add_argument("--plots-port", type=int, default=9090)
    p.add_argument("--plots-grpc-port", type=int, default=9876, help="rerun's gRPC port (the viewer reads from it)")
    p.add_argument("--plots-max-hz", type=float, default=10.0,
                   help="numbers are plotted at most this often per stream (state lanes get every change)")
    p.add_argument("--plots-all-topics", action="store_true",
                   help="plot every numeric field of every topic (heavy on a small laptop; the panel adds topics "
                        "one by one)")
    p.add_argument("--recordings", default=None, metavar="DIR", help="recordings folder (default: recordings/)")
    p.add_argument("--no-auto-record", action="store_true", help="do not record matches automatically")
    p.add_argument("--replay", default=None, metavar="FILE", help="open this MCAP log in the replay source")
    p.add_argument("--log-level", default="INFO")
    return p


def config_from(args: argparse.Namespace) -> ServerConfig:
    bus = BusConfig(config_file=args.zenoh_config)
    if args.connect:
        bus.connect = args.connect
    if args.zenoh_config:
        try:
            load_config_file(args.zenoh_config)  # said at start, not when the first panel opens the session
        except ValueError as exc:
            raise SystemExit(str(exc)) from None
    packages = {}
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
    try:
        return ServerConfig(match_mode=args.match, host=args.host, port=args.port, token=args.token, bus=bus,
                            live_source=False if (args.no_live or args.match) else None,
                            telemetry_source=not args.no_telemetry, telemetry_host=args.telemetry_host,
                            telemetry_port=args.telemetry_port, telemetry_key=args.telemetry_key, robot3d=args.robot3d,
                            robot3d_port=args.robot3d_port, descriptions=descriptions, plots=args.plots,
                            plots_web_port=args.plots_port,
                            plots_grpc_port=args.plots_grpc_port, plots_max_hz=args.plots_max_hz,
                            plots_all_topics=args.plots_all_topics)
    except ValueError as exc:
        raise SystemExit(str(exc)) from None


def start_banner(config: ServerConfig) -> str:
    shown = "127.0.0.1" if config.host in ("0.0.0.0", "::") else config.host
    lines = [f"pitchside dashboard: http://{shown}:{config.port}/"]
    if config.match_mode:
        lines.append("MATCH MODE: telemetry only, nothing is sent to robots, control is off")
    if config.needs_token:
        lines.append(f"control token: {config.token}  (header 'Authorization: Bearer <token>' or ?token=)")
    return "\n".join(lines)


def serve(argv: list[str] | None = None) -> None:
    import uvicorn

    from server.app import create_app

    args = arguments().parse_args(argv)
    logging.basicConfig(level=args.log_level, format="%(asctime)s %(levelname)s [server] %(message)s")
    config = config_from(args)
    if args.recordings:
        config.recordings_dir = Path(args.recordings)
    config.auto_record_matches = not args.no_auto_record
    config.replay_file = Path(args.replay) if args.replay else None
    app = create_app(config)
    print(start_banner(config), flush=True)
    # an open browser holds endless streams (parameter events): on SIGTERM/Ctrl-C wait for them at most 2 s
    uvicorn.run(app, host=config.host, port=config.port, log_level=args.log_level.lower(), access_log=False,
                timeout_graceful_shutdown=2)


if __name__ == "__main__":
    serve(sys.argv[1:])
