"""`pitchside <command>`: one entry point for the demo, the robot, the dashboard and the tools."""

from __future__ import annotations

import importlib
import inspect
import sys
from collections.abc import Callable

# command -> (module with a main(argv) function, one line of help)
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("pitchside.demo", "simulated world + robot nodes + GameController + dashboard; prints the URL"),
    "robot": ("pitchside.robot", "one robot's nodes as supervised processes (simulated by default)"),
    "sim": ("robot_nodes.cm730.sim.__main__", "the MuJoCo world and one cm730 node per robot (robot1..N)"),
    "serve": ("server.__main__", "the dashboard server (live Zenoh and UDP telemetry sources)"),
    "router": ("robot_nodes.runtime.router", "a Zenoh router for robots and dashboards on several machines"),
    "team-keys": ("pitchside.team_keys", "a team's CA, certificates, access control and Zenoh configs (secured bus)"),
    "launch": ("robot_nodes.launch", "start named nodes as supervised processes"),
    "gamecontroller": ("robot_nodes.game_controller.simulator", "a simulated RoboCup GameController"),
    "record": ("pitchside.record", "start/stop/list recordings of a running dashboard server"),
    "replay": ("pitchside.replay", "the dashboard with an MCAP log (pitchside or ROS 2 bag) in the replay source"),
    "export-rerun": ("pitchside.export_rerun", "a log's numeric fields as rerun scalars (.rrd)"),
    "telemetry-key": ("robot_nodes.telemetry.keygen", "a new team key for telemetry (robots and the match dashboard)"),
}


def usage() -> str:
    width = max(len(c) for c in COMMANDS)
    lines = ["usage: pitchside <command> [options]   (pitchside <command> --help for its options)", "",
             "commands:"]
    lines += [f"  {name.ljust(width)}  {text}" for name, (_, text) in COMMANDS.items()]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    args = sys.argv[1:] if argv is None else argv
    if not args or args[0] in ("-h", "--help", "help"):
        print(usage())
        return
    command, rest = args[0], args[1:]
    if command not in COMMANDS:
        print(f"pitchside: unknown command {command!r}\n\n{usage()}", file=sys.stderr)
        raise SystemExit(2)
    module = importlib.import_module(COMMANDS[command][0])
    entry: Callable[..., None] = getattr(module, "main", None) or module.serve
    sys.argv = [f"pitchside {command}", *rest]
    # entry points either take argv or read sys.argv themselves
    entry(rest) if inspect.signature(entry).parameters else entry()


if __name__ == "__main__":
    main()
