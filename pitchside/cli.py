"""`pitchside <command>`: one entry point for the demo, the robot, the dashboard and the tools."""

from __future__ import annotations

import importlib
import importlib.metadata
import sys
from collections.abc import Callable
from typing import cast

from wire.command_line import EXIT_CODES

# command -> ("module:function" taking argv, one line of help)
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("pitchside.demo:main", "simulated world + robot nodes + GameController + dashboard; prints the link"),
    "match": ("pitchside.match:main", "two teams of simulated robots play under the GameController; the match "
              "dashboard watches and records each half"),
    "robot": ("pitchside.robot:main", "everything a robot runs, with its own Zenoh router (simulated by default)"),
    "doctor": ("pitchside.doctor:main", "on the robot: checks serial port, router, clock, disk, telemetry key and "
               "GameController, and says how to fix what fails"),
    "sim": ("robot_nodes.cm730.sim.__main__:main", "the MuJoCo world and one cm730 node per robot (robot1..N)"),
    "serve": ("server.__main__:serve", "the dashboard server (live Zenoh and UDP telemetry sources)"),
    "router": ("robot_nodes.runtime.router:main", "a Zenoh router for robots and dashboards on several machines"),
    "team-keys": ("pitchside.team_keys:main", "a team's CA, certificates, access control and Zenoh configs (secured "
                  "bus)"),
    "launch": ("robot_nodes.launch:main", "start named nodes as supervised processes"),
    "gamecontroller": ("robot_nodes.game_controller.simulator:main", "a simulated RoboCup GameController"),
    "record": ("pitchside.record:main", "start/stop/list recordings of a running dashboard server"),
    "replay": ("pitchside.replay:main", "the dashboard with an MCAP log (pitchside or ROS 2 bag) in the replay source"),
    "export-rerun": ("pitchside.export_rerun:main", "a log's numeric fields as rerun scalars (.rrd)"),
    "telemetry-key": ("robot_nodes.telemetry.keygen:main", "a new team key for telemetry (robots and the match "
                      "dashboard)"),
}


def entry_point(command: str) -> Callable[[list[str]], None]:
    module, _, function = COMMANDS[command][0].partition(":")
    return cast(Callable[[list[str]], None], getattr(importlib.import_module(module), function))


def version() -> str:
    """The installed distribution's version (a checkout run without installing says so)."""
    try:
        return importlib.metadata.version("pitchside")
    except importlib.metadata.PackageNotFoundError:
        return "unknown (not installed: pip install -e .)"


def usage() -> str:
    width = max(len(c) for c in COMMANDS)
    lines = ["usage: pitchside <command> [options]   (pitchside <command> --help for its options)",
             "       pitchside --version", "", "commands:"]
    lines += [f"  {name.ljust(width)}  {text}" for name, (_, text) in COMMANDS.items()]
    lines += ["", EXIT_CODES]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    args = sys.argv[1:] if argv is None else argv
    if not args or args[0] in ("-h", "--help", "help"):
        print(usage())
        return
    if args[0] in ("-V", "--version"):
        print(f"pitchside {version()}")
        return
    command, rest = args[0], args[1:]
    if command not in COMMANDS:
        print(f"pitchside: unknown command {command!r}\n\n{usage()}", file=sys.stderr)
        raise SystemExit(2)
    sys.argv = [f"pitchside {command}", *rest]  # what argparse names the program in its messages
    entry_point(command)(rest)


if __name__ == "__main__":
    main()
