"""`pitchside <command>`: one entry point for the demo, the robot, the dashboard and the tools.

Each command names the install profile it needs; one whose packages are missing says in one line what to install
(exit status 2) instead of failing with a traceback somewhere inside its imports. This module and pitchside.profiles
need only the standard library and wire, so they run on any install.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable
from typing import NamedTuple, cast

from pitchside import __version__, profiles
from wire.command_line import EXIT_CODES

EXIT_PROFILE_MISSING = 2  # as a usage error: the command cannot start as installed


class Command(NamedTuple):
    target: str  # "module:function" taking argv
    profile: str  # the install profile it needs (pitchside.profiles.PROFILES)
    text: str  # one line of help


# the one table of commands: what runs each, the profile it needs, its line in --help
COMMANDS: dict[str, Command] = {
    "demo": Command("pitchside.demo:main", "all", "simulated world + robot nodes + GameController + dashboard; "
                    "prints the link"),
    "match": Command("pitchside.match:main", "all", "two teams of simulated robots play under the GameController; "
                     "the match dashboard watches and records each half"),
    "robot": Command("pitchside.robot:main", "robot", "everything a robot runs, with its own Zenoh router (simulated "
                     "by default: the sim profile)"),
    "doctor": Command("pitchside.doctor:main", "core", "checks a robot (serial port, router, clock, disk, telemetry "
                      "key, GameController) or the team laptop (profile, ports, router) and says how to fix it"),
    "sim": Command("robot_nodes.sim.__main__:main", "sim", "the MuJoCo world and one cm730 node per robot "
                   "(robot1..N)"),
    "serve": Command("server.__main__:serve", "dashboard", "the dashboard server (live Zenoh and UDP telemetry "
                     "sources)"),
    "router": Command("robot_nodes.runtime.router:main", "core", "a Zenoh router for robots and dashboards on "
                      "several machines"),
    "team-keys": Command("pitchside.team_keys:main", "core", "a team's CA, certificates, access control and Zenoh "
                         "configs (secured bus)"),
    "launch": Command("robot_nodes.launch:main", "robot", "start named nodes as supervised processes"),
    "gamecontroller": Command("robot_nodes.sim.gamecontroller:main", "core", "a simulated RoboCup "
                              "GameController"),
    "record": Command("pitchside.record:main", "dashboard", "start/stop/list recordings of a running dashboard "
                      "server"),
    "logs": Command("pitchside.logs:main", "dashboard", "after a game: fetch each robot's own log of a half (bus or "
                    "SSH) and merge it with the laptop's match log into one timeline"),
    "replay": Command("pitchside.replay:main", "dashboard", "the dashboard with an MCAP log (pitchside or ROS 2 bag) "
                      "in the replay source"),
    "export-rerun": Command("pitchside.export_rerun:main", "dashboard", "a log's numeric fields as rerun scalars "
                            "(.rrd)"),
    "telemetry-key": Command("pitchside.telemetry_key:main", "core", "a new team key for telemetry (robots and the "
                             "match dashboard)"),
}
# the program's own top-level packages: a missing module among them is a broken install, not a missing profile
OWN_PACKAGES = frozenset({"pitchside", "schemas", "wire", "robot_nodes", "server", "robots", "web"})


def entry_point(command: str) -> Callable[[list[str]], None]:
    module, _, function = COMMANDS[command].target.partition(":")
    return cast(Callable[[list[str]], None], getattr(importlib.import_module(module), function))


def version() -> str:
    return __version__


def usage() -> str:
    installed = profiles.installed()
    width = max(len(c) for c in COMMANDS)
    tags = {name: f"[{c.profile}]" for name, c in COMMANDS.items()}
    tag_width = max(len(t) for t in tags.values())
    lines = ["usage: pitchside <command> [options]   (pitchside <command> --help for its options)",
             "       pitchside --version", "",
             "commands ([the install profile each needs]; * = its profile is installed here):"]
    lines += [f"{'*' if c.profile in installed else ' '} {name.ljust(width)}  {tags[name].ljust(tag_width)}  {c.text}"
              for name, c in COMMANDS.items()]
    others = [p for p in profiles.PROFILES if p not in installed]
    lines += ["", f"installed profiles: {', '.join(installed) or 'none (the core is incomplete)'}"]
    if others:
        lines.append("another profile: pip install 'pitchside[PROFILE]' (from a clone: pip install --require-hashes "
                     "-r locks/PROFILE.txt)")
    lines += ["", EXIT_CODES, "(2 also when the command's install profile is missing: one line names it)"]
    return "\n".join(lines)


def refuse(command: str, absent: list[str]) -> None:
    """The one line that says what to install, and the exit status of a command that cannot start."""
    print(profiles.needs_line(command, COMMANDS[command].profile, absent), file=sys.stderr)
    raise SystemExit(EXIT_PROFILE_MISSING)


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
    absent = profiles.missing(COMMANDS[command].profile)
    if absent:
        refuse(command, absent)
    sys.argv = [f"pitchside {command}", *rest]  # what argparse names the program in its messages
    try:
        run = entry_point(command)
    except ModuleNotFoundError as exc:
        # the metadata said the profile is there (or pitchside runs uninstalled from a checkout): a package of the
        # profile that is still missing is named the same way; a missing module of our own is a broken install
        if not exc.name or exc.name.split(".")[0] in OWN_PACKAGES:
            raise
        refuse(command, [exc.name.split(".")[0]])
    run(rest)


if __name__ == "__main__":
    main()
