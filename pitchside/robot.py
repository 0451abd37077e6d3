"""`pitchside robot`: one robot's nodes as supervised processes (the simulated robot by default)."""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

from pitchside.team_access import Role
from pitchside.team_keys import member_of
from robot_nodes.launch import NODE_MODULES, Launcher, NodeProcess, node_command, run_until_signal
from robot_nodes.runtime.bus import DEFAULT_ROUTER, load_config_file

REPO = Path(__file__).resolve().parents[1]
MOTION_NODES = ["hcm", "animation", "pause", "speaker"]


def params_file(model: str) -> Path:
    return REPO / "robots" / model / "params.yaml"


def robot_nodes(robot_id: str, connect: list[str], model: str, names: list[str],
                extra: dict[str, list[str]] | None = None, zenoh_config: str | Path | None = None) -> list[NodeProcess]:
    """The supervised processes of one robot; extra[name] adds arguments to that node."""
    params = params_file(model)
    processes = []
    for name in names:
        module = NODE_MODULES[name]
        args = list((extra or {}).get(name, []))
        processes.append(NodeProcess(f"{robot_id}/{name}", node_command(
            module, robot_id, connect, params if params.exists() else None, args, zenoh_config)))
    return processes


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
        if robot_id and robot_id != name:
            raise SystemExit(f"pitchside robot: {zenoh_config} is {name}'s team config, not {robot_id}'s (the team's "
                             f"access control would drop everything {robot_id} sends)")
        return name
    return robot_id or "robot1"


def available(names: list[str]) -> list[str]:
    """Nodes whose module exists in this checkout (parts of the stack may still be missing)."""
    import importlib.util

    def runnable(module: str) -> bool:
        spec = importlib.util.find_spec(module)
        if spec is None:
            return False
        return spec.submodule_search_locations is None or importlib.util.find_spec(f"{module}.__main__") is not None

    return [n for n in names if runnable(NODE_MODULES[n])]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="pitchside robot", description=__doc__)
    parser.add_argument("--robot-id", default=None, help="robot id (default: the team config's robot, else robot1)")
    parser.add_argument("--model", default="minibot", help="robot description folder under robots/")
    parser.add_argument("--connect", action="append", default=None, help=f"Zenoh endpoint (default {DEFAULT_ROUTER})")
    parser.add_argument("--nodes", default=",".join(["cm730", *MOTION_NODES, "walking"]),
                        help="comma-separated nodes to start")
    parser.add_argument("--zenoh-config", default=None, metavar="FILE",
                        help="Zenoh JSON5 config for every node (overrides --connect), e.g. the robot's file from "
                             "`pitchside team-keys`")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s [robot] %(message)s")
    if args.zenoh_config:
        try:
            load_config_file(args.zenoh_config)
        except ValueError as exc:
            raise SystemExit(f"pitchside robot: {exc}") from None
    robot_id = robot_id_for(args.robot_id, args.zenoh_config)
    names = available([n.strip() for n in args.nodes.split(",") if n.strip()])
    run_until_signal(Launcher(robot_nodes(robot_id, args.connect or [DEFAULT_ROUTER], args.model, names,
                                          zenoh_config=args.zenoh_config)))


if __name__ == "__main__":
    main()
