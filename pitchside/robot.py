"""`pitchside robot`: everything one robot runs, as supervised processes, with the robot's own Zenoh router.

The robot is one machine: its router (inside this process) lets its nodes meet on the robot and, in the lab,
links the robot to the team laptop's router (``--connect``). In a match (``--match``) it connects nowhere, and the
robot's only traffic to the team PC is its one-way telemetry (``--telemetry-to``). On a team's secured bus the
router takes the robot's file from ``pitchside team-keys`` (``--zenoh-config``: mutual TLS to the team router, the
access control); the nodes join it on loopback as always and never hold the robot's key.
"""

from __future__ import annotations

import argparse
import importlib.util
import logging
import sys
from pathlib import Path

import robots
from pitchside.service import DEFAULT_UNIT, UNIT_DIR, RobotService, ServiceError, install, invoking_user, robot_program
from pitchside.team_access import Role
from pitchside.team_keys import member_of
from robot_nodes.catalog import MOTION_NODES, NODE_MODULES
from robot_nodes.launch import (
    COMPOSE_HELP,
    Launcher,
    NodeProcess,
    RobotNodes,
    process_groups,
    robot_processes,
    run_until_signal,
    shared_process,
)
from wire.bus import add_bus_arguments, env_endpoints, load_config_file
from wire.command_line import CommandParser
from wire.machine_router import MachineRouter, is_router_config, start_machine_router
from wire.team_key import secured_bus, team_key_beside
from wire.telemetry.datagram import DEFAULT_PORT

# everything a robot runs in a match (telemetry only when it has somewhere to send to)
ROBOT_NODES = ["cm730", *MOTION_NODES, "walking", "game_controller", "mitecom", "telemetry"]


def params_file(model: str) -> Path:
    return robots.params_file(model)


def robot_nodes(robot_id: str, connect: list[str], *, model: str, names: list[str],
                extra: dict[str, list[str]] | None = None, zenoh_config: str | Path | None = None,
                params: Path | None = None, mode: str = "auto", compose: str = "all",
                alone: list[str] | None = None) -> list[NodeProcess]:
    """The supervised processes of one robot (which nodes share one: launch.process_groups); extra[name] adds
    arguments to that node."""
    params = params or params_file(model)
    groups = process_groups(names, compose, alone)
    return robot_processes(robot_id, groups, connect, params=params if params.exists() else None, extra=extra,
                           zenoh_config=zenoh_config, mode=mode)


def simulated_robots(robots: list[RobotNodes], connect: list[str], *, model: str, compose: str = "all",
                     per_process: int = 1) -> list[NodeProcess]:
    """The processes of simulated robots: with compose "all", per_process robots to a process (launch.shared_process;
    a group of one as robot_nodes makes it), otherwise each robot's own as robot_nodes makes them."""
    size = per_process if compose == "all" else 1
    processes: list[NodeProcess] = []
    for first in range(0, len(robots), size):
        group = robots[first:first + size]
        if len(group) > 1:
            processes.append(shared_process(group, connect, params=params_file(model)))
        else:
            processes += robot_nodes(group[0].robot_id, connect, model=model, names=group[0].nodes,
                                     extra=group[0].extra, compose=compose)
    return processes


def robot_log_process(robot_id: str, endpoint: str, match: bool, folder: Path | None, cap_bytes: int | None
                      ) -> NodeProcess:
    """The robot's own log (robot_nodes.robot_log): records every topic at full rate in a match, and serves the
    files to `pitchside logs pull` in the lab (where it records nothing: the dashboard records the bus)."""
    argv = [sys.executable, "-m", "robot_nodes.robot_log", "--robot-id", robot_id, "--connect", endpoint]
    if folder is not None:
        argv += ["--folder", str(folder)]
    if cap_bytes is not None:
        argv += ["--cap-bytes", str(cap_bytes)]
    return NodeProcess(f"{robot_id}/robot_log", argv if match else [*argv, "--no-record"])


def robot_id_for(robot_id: str | None, zenoh_config: str | None) -> str:
    """The robot id: as given, else the robot a team config file belongs to, else robot1.

    A robot whose id is not the one in its team certificate would have everything it sends dropped by the team's
    access control, so that is refused here with the reason.
    """
    member = member_of(zenoh_config) if zenoh_config else None
    if member is not None:
        name, role = member
        if role is not Role.ROBOT:
            raise SystemExit(f"pitchside robot: {zenoh_config} is the team config of {name} ({role.value}), "
                             "not of a robot")
        if zenoh_config and not is_router_config(zenoh_config):
            raise SystemExit(f"pitchside robot: {zenoh_config} is {name}'s file from an older `pitchside team-keys` "
                             "(a peer of the team router; now each robot runs its own router): write the team's "
                             "files again, keeping the keys, with `pitchside team-keys FOLDER --rewrite`")
        if robot_id and robot_id != name:
            raise SystemExit(f"pitchside robot: {zenoh_config} is {name}'s team config, not {robot_id}'s (the team's "
                             f"access control would drop everything {robot_id} sends)")
        return name
    return robot_id or "robot1"


def robot_router(args: argparse.Namespace) -> MachineRouter:
    """The robot's own router: from the robot's file (--zenoh-config: its endpoints unless --listen/--connect)
    or from --listen/--connect; in a match it connects nowhere, whatever the file says."""
    if args.match:
        connect: list[str] | None = []
    elif args.zenoh_config:
        connect = args.connect or None  # None: the file's, the team router over TLS
    else:
        connect = args.connect or env_endpoints()
    try:
        return start_machine_router(args.listen, connect, args.zenoh_config)
    except ValueError as exc:
        raise SystemExit(f"pitchside robot: {exc}") from None


def available(names: list[str]) -> list[str]:
    """Nodes whose module exists in this checkout (parts of the stack may still be missing)."""
    import importlib.util

    def runnable(module: str) -> bool:
        spec = importlib.util.find_spec(module)
        if spec is None:
            return False
        return spec.submodule_search_locations is None or importlib.util.find_spec(f"{module}.__main__") is not None

    return [n for n in names if runnable(NODE_MODULES[n])]


def telemetry_arguments(args: argparse.Namespace) -> list[str] | None:
    """The telemetry node's settings, or None when the robot sends no telemetry (the lab without a destination)."""
    if not args.telemetry_to:
        if args.match:
            raise SystemExit("pitchside robot --match: the robot's telemetry is all the team PC gets in a match; "
                             "give --telemetry-to TEAM_PC[:PORT]")
        return None
    out = ["--set", f"destination={args.telemetry_to}"]
    if args.telemetry_key:
        out += ["--set", f"team_key={Path(args.telemetry_key).resolve()}"]
    elif args.allow_dev_key:
        out += ["--set", "allow_dev_key=true"]
    elif args.match:
        raise SystemExit("pitchside robot --match: give the team's telemetry key (--telemetry-key FILE, made by "
                         "`pitchside telemetry-key`); --allow-dev-key sends under the published development key")
    return out


def team_key_arguments(args: argparse.Namespace) -> None:
    """The team key: --telemetry-key, else team.key beside a secured team's file; a secured team never falls back
    to the published development key (its bus would be bypassed over UDP)."""
    if not args.zenoh_config or not secured_bus(args.zenoh_config):
        return
    if args.allow_dev_key:
        raise SystemExit("pitchside robot: a secured team's robot never sends under the published development key; "
                         "drop --allow-dev-key (the team's key is team.key, written by `pitchside team-keys`)")
    if not args.telemetry_key:
        found = team_key_beside(args.zenoh_config)
        args.telemetry_key = str(found) if found else None


def team_comm_arguments(args: argparse.Namespace) -> list[str]:
    """The team communication's settings: signed with the team key; on the field's network only in a match (or
    where --team-comm-address says), loopback in the lab."""
    out: list[str] = []
    if "mitecom" not in [n.strip() for n in args.nodes.split(",")]:
        return out
    if args.unsigned_team_messages:
        out += ["--set", "unsigned=true"]
    elif args.telemetry_key:
        out += ["--set", f"team_key={Path(args.telemetry_key).resolve()}"]
    elif args.match:
        raise SystemExit("pitchside robot --match: team messages are signed with the team's key (--telemetry-key "
                         "FILE); --unsigned-team-messages sends and believes unsigned ones (a mixed team whose "
                         "partners do not sign: anyone on the field can then forge a teammate)")
    address = args.team_comm_address or ("0.0.0.0" if args.match else None)
    if address:
        out += ["--set", f"listen_address={address}"]
    return out


def service_command(args: argparse.Namespace, robot_id: str) -> list[str]:
    """This command line again, for the unit: the same options, paths absolute, the service's own options left out."""
    command = [*robot_program(), "robot", "--robot-id", robot_id, "--model", args.model]
    if args.params:
        command += ["--params", str(args.params.resolve())]
    if args.nodes != ",".join(ROBOT_NODES):
        command += ["--nodes", args.nodes]
    for option, values in (("--connect", args.connect), ("--listen", args.listen)):
        for value in values or []:
            command += [option, value]
    if args.mode != "auto":
        command += ["--mode", args.mode]
    if args.zenoh_config:
        command += ["--zenoh-config", str(Path(args.zenoh_config).resolve())]
    if args.telemetry_to:
        command += ["--telemetry-to", args.telemetry_to]
    if args.telemetry_key:
        command += ["--telemetry-key", str(Path(args.telemetry_key).resolve())]
    if args.allow_dev_key:
        command.append("--allow-dev-key")
    if args.unsigned_team_messages:
        command.append("--unsigned-team-messages")
    if args.team_comm_address:
        command += ["--team-comm-address", args.team_comm_address]
    if args.match:
        command.append("--match")
    return command


def install_service(args: argparse.Namespace) -> None:
    """--install-service: the same checks as a start (a unit that would only fail at boot is refused now)."""
    if args.zenoh_config:
        try:
            load_config_file(args.zenoh_config)
        except ValueError as exc:
            raise SystemExit(f"pitchside robot: {exc}") from None
    if args.params and not args.params.is_file():
        raise SystemExit(f"pitchside robot: params file {args.params} does not exist")
    robot_id = robot_id_for(args.robot_id, args.zenoh_config)
    team_key_arguments(args)
    telemetry_arguments(args)
    team_comm_arguments(args)
    unit = RobotService(service_command(args, robot_id), args.service_user or invoking_user(), Path.cwd(), robot_id,
                        args.service_name)
    if args.dry_run:
        print(unit.unit_text(), end="")
        return
    try:
        for line in install(unit, args.unit_dir):
            print(line)
    except ServiceError as exc:
        raise SystemExit(f"pitchside robot: {exc}") from None


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(prog="pitchside robot", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--robot-id", default=None, help="robot id (default: the team config's robot, else robot1)")
    parser.add_argument("--model", default="minibot", help="robot description folder under robots/")
    parser.add_argument("--params", type=Path, default=None,
                        help="the robot's params.yaml (default robots/<model>/params.yaml)")
    parser.add_argument("--nodes", default=",".join(ROBOT_NODES),
                        help="comma-separated nodes to start (telemetry only with --telemetry-to)")
    parser.add_argument("--compose", default="all", help=COMPOSE_HELP + " (default all, but cm730 alone)")
    parser.add_argument("--alone", action="append", default=None, metavar="NODE",
                        help="with --compose all: this node runs in a process of its own (repeatable; default "
                             "cm730, whose bus timing must not wait on other nodes' callbacks)")
    add_bus_arguments(parser, connect_help="the team laptop's Zenoh router, in the lab (repeatable; the robot's "
                                           "own router connects to it); none in a match",
                      config_help="the robot's file from `pitchside team-keys`: its router's config (mutual TLS, "
                                  "access control); the nodes join that router on loopback")
    parser.add_argument("--telemetry-to", default=None, metavar="HOST[:PORT]",
                        help=f"the team PC's telemetry listener (UDP, port {DEFAULT_PORT} by default)")
    parser.add_argument("--telemetry-key", default=None, metavar="FILE",
                        help="the team's key file (telemetry and signed team messages; default on a secured team: "
                             "team.key beside --zenoh-config)")
    parser.add_argument("--allow-dev-key", action="store_true",
                        help="send telemetry under the published development key (lab only)")
    parser.add_argument("--unsigned-team-messages", action="store_true",
                        help="send and believe unsigned team messages (a mixed team whose partners do not sign)")
    parser.add_argument("--team-comm-address", default=None, metavar="ADDRESS",
                        help="where the team communication listens (default 127.0.0.1 in the lab, 0.0.0.0 with "
                             "--match)")
    parser.add_argument("--log-folder", type=Path, default=None,
                        help="where the robot's own log goes in a match (default $PITCHSIDE_ROBOT_LOGS, else "
                             "./robot_logs); `pitchside logs pull` fetches it after the game")
    parser.add_argument("--log-cap-bytes", type=int, default=None,
                        help="the most the robot's log folder holds (default 8 GiB); the oldest halves go first")
    parser.add_argument("--match", action="store_true",
                        help="match configuration: the robot's Zenoh connects to nobody (nothing reaches the team "
                             "PC but the telemetry, nothing needs to come back); needs --telemetry-to and a key")
    service = parser.add_argument_group("as a systemd service (docs/guides/on-the-robot.md)")
    service.add_argument("--install-service", action="store_true",
                         help="write a systemd unit that runs this command with these options at every boot "
                              "(restart on failure, output to the journal), enable it, and exit")
    service.add_argument("--dry-run", action="store_true", help="with --install-service: print the unit, write nothing")
    service.add_argument("--service-user", default=None, metavar="USER",
                         help="who the service runs as (default: you, also under sudo)")
    service.add_argument("--service-name", default=DEFAULT_UNIT, metavar="NAME", help="the unit's name")
    service.add_argument("--unit-dir", type=Path, default=UNIT_DIR, metavar="DIR",
                         help=f"where the unit is written (default {UNIT_DIR}; enabled only there)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s [robot] %(message)s")
    if args.install_service:
        install_service(args)
        return
    if args.zenoh_config:
        try:
            load_config_file(args.zenoh_config)
        except ValueError as exc:
            raise SystemExit(f"pitchside robot: {exc}") from None
    if args.match and args.connect:
        raise SystemExit("pitchside robot --match: a robot in a match connects to no other machine (the team PC "
                         "would answer with packets the rules forbid); drop --connect")
    robot_id = robot_id_for(args.robot_id, args.zenoh_config)
    team_key_arguments(args)
    telemetry = telemetry_arguments(args)
    team_comm = team_comm_arguments(args)
    wanted = [n.strip() for n in args.nodes.split(",") if n.strip()]
    if telemetry is None and "telemetry" in wanted:
        wanted.remove("telemetry")
        logging.info("no telemetry (no --telemetry-to): in the lab the dashboard reads the bus")
    names = available(wanted)
    alone = ["cm730"] if args.alone is None else args.alone
    try:
        process_groups(names, args.compose, alone)
    except ValueError as exc:
        parser.error(str(exc))
    router = robot_router(args)
    # the nodes join the robot's router on loopback; a team file (the robot's key) stays with the router
    processes = robot_nodes(robot_id, [router.local_endpoint], model=args.model, names=names,
                            extra={"telemetry": telemetry or [], "mitecom": team_comm}, params=args.params,
                            mode=args.mode, compose=args.compose, alone=alone)
    if importlib.util.find_spec("mcap") is not None:
        processes.append(robot_log_process(robot_id, router.local_endpoint, args.match, args.log_folder,
                                           args.log_cap_bytes))
    else:  # the robot profile without the log writer's packages: the robot plays, unlogged, and says so
        logging.warning("no robot log: the mcap package is not installed (pip install mcap zstandard)")
    launcher = Launcher(processes)
    try:
        run_until_signal(launcher)
    finally:
        router.close()


if __name__ == "__main__":
    main()
