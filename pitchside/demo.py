"""`pitchside demo`: the simulated world, its robots' nodes, a simulated GameController and the dashboard.

Everything runs on this machine: a Zenoh router inside this process, the other parts as supervised processes
(pitchside/local_run.py, which `pitchside match` shares).
"""

from __future__ import annotations

import logging
import os
import sys
from pathlib import Path

import robots as descriptions
from pitchside.local_run import (
    ROBOTS_PER_PROCESS,
    DashboardPlan,
    dashboard_processes,
    free_port,
    kernel_port,
    run_on_this_machine,
    telemetry_image_rate,
    telemetry_settings,
    world_first,
)
from robot_nodes.catalog import MOTION_NODES
from robot_nodes.launch import COMPOSE_HELP, NodeProcess, RobotNodes, process_groups
from server.profiles.flags import add_ros2_arguments, ros2_flags, ros2_setup
from server.security.credentials import ENV_TOKEN, new_token
from wire.command_line import CommandParser

log = logging.getLogger("pitchside.demo")
DEMO_ROBOT_NODES = [*MOTION_NODES, "walking", "game_controller", "telemetry"]  # cm730: in the world's process


def demo_processes(*, robots: int, endpoint: str, http_port: int, dashboard: DashboardPlan, model: str,
                   match: bool, gc_ports: list[int], gc_return_port: int,
                   token: str = "",
                   telemetry_key: Path | None = None, compose: str = "all", cameras: int = 1,
                   robots_per_process: int = 1, server_flags: list[str] | None = None) -> list[NodeProcess]:
    """Every process of the demo.

    dashboard: the ports of the dashboard and its recorder; token: the dashboard's control token;
    telemetry_key: a key file the robots and the dashboard share;
    robots_per_process: with compose "all", that many robots' nodes share a process (shared_process);
    server_flags: more flags of the dashboard (the --ros-* ones: ROS 2 robots of other teams beside the demo's)."""
    py = sys.executable
    connect = ["--connect", endpoint]
    world = [py, "-m", "robot_nodes.sim", "--robots", str(robots), "--cameras", str(cameras), *connect,
             "--params", str(descriptions.params_file(model))]
    if match:  # the dashboard sees images only through telemetry: render no more than it sends
        world += ["--set", f"image_rate={telemetry_image_rate()}"]
    from pitchside.robot import available, simulated_robots  # the team's keys and access rules: not for --help

    processes = [NodeProcess("world", world)]
    per_robot = available(DEMO_ROBOT_NODES)
    sharing: list[RobotNodes] = []
    for i in range(1, robots + 1):
        extra = {
            # everything of the demo is on this machine: nothing listens beyond loopback (README "Security at
            # the venue"); a real robot hears the GameController's broadcast on every interface
            "game_controller": ["--set", f"player_number={i}", "--set", f"listen_port={gc_ports[i - 1]}",
                                "--set", "listen_address=127.0.0.1", "--set", f"return_port={gc_return_port}"],
            "telemetry": telemetry_settings(dashboard.robots_port, telemetry_key),
        }
        sharing.append(RobotNodes(f"robot{i}", per_robot, extra))
    processes += simulated_robots(sharing, [endpoint], model=model, compose=compose, per_process=robots_per_process)
    gc = [py, "-m", "robot_nodes.sim.gamecontroller", "--players-per-team", str(max(robots, 4)),
          "--return-address", f"127.0.0.1:{gc_return_port}"]
    for port in gc_ports:
        gc += ["--to", f"127.0.0.1:{port}"]
    processes.append(NodeProcess("gamecontroller", gc))
    processes += dashboard_processes(dashboard, http_port=http_port, model=model, connect=[endpoint], match=match,
                                     token=token, telemetry_key=telemetry_key, extra=server_flags or [],
                                     spares=False)
    return world_first(processes)


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(prog="pitchside demo", description=__doc__)
    parser.add_argument("--robots", type=int, default=1, help="robots in the world (default 1)")
    parser.add_argument("--port", type=int, default=8080, help="dashboard port (a free one if taken)")
    parser.add_argument("--model", default="minibot")
    parser.add_argument("--match", action="store_true", help="dashboard in match mode (telemetry only)")
    parser.add_argument("--cameras", type=int, default=1,
                        help="how many robots render head camera images (default 1: robot1's; the others still "
                             "see the ball, goals and robots through the perception stand-ins)")
    parser.add_argument("--compose", default="all",
                        help=COMPOSE_HELP + " (default all: each robot's nodes in one process; the simulated "
                             "servo buses of all robots run in the world's process)")
    parser.add_argument("--robots-per-process", type=int, default=ROBOTS_PER_PROCESS,
                        help=f"with --compose all: how many robots' nodes share a process (default "
                             f"{ROBOTS_PER_PROCESS}; 1: a process per robot, as on real robots)")
    add_ros2_arguments(parser)
    args = parser.parse_args(argv)
    ros2_setup(args)  # a bad --ros-* flag or file is said here, not by the dashboard's process later
    if args.robots_per_process < 1:
        parser.error("--robots-per-process must be at least 1")
    try:
        process_groups(DEMO_ROBOT_NODES, args.compose)
    except ValueError as exc:
        parser.error(str(exc))
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s [demo] %(message)s")
    endpoint = f"tcp/127.0.0.1:{free_port(7447)}"
    http_port = free_port(args.port)
    # the robots' telemetry, the simulated GameController and the robots' receivers talk on this machine only: the
    # kernel's free ports (local_run.kernel_port)
    dashboard = DashboardPlan.fresh()
    gc_ports = [kernel_port() for _ in range(args.robots)]
    gc_return_port = kernel_port()
    token = os.environ.get(ENV_TOKEN) or new_token()
    run_on_this_machine("demo", endpoint, http_port, token, lambda key: demo_processes(
        robots=args.robots, endpoint=endpoint, http_port=http_port, dashboard=dashboard, model=args.model,
        match=args.match, gc_ports=gc_ports, gc_return_port=gc_return_port, token=token, telemetry_key=key,
        compose=args.compose, cameras=args.cameras, robots_per_process=args.robots_per_process,
        server_flags=ros2_flags(args)), dashboard=dashboard)


if __name__ == "__main__":
    main()
