"""`pitchside match`: two teams of simulated robots play a game under the GameController, the dashboard watches.

One MuJoCo world with both teams and the referee (robot_nodes/sim/match.py), each robot's nodes as the demo
starts them (composed per robot), the simulated GameController on the world's clock (or a real one on the network:
``--gamecontroller external``), and the dashboard in match mode: it hears the robots' one-way telemetry only and
records each half. Everything but an external GameController runs on this machine (pitchside/local_run.py).
"""

from __future__ import annotations

import logging
import math
import os
import sys
from dataclasses import dataclass
from pathlib import Path

import robots as descriptions
from pitchside.local_run import (
    ROBOTS_IN_MATCH_NICE,
    ROBOTS_PER_PROCESS,
    DashboardPlan,
    dashboard_processes,
    free_port,
    kernel_port,
    kernel_ports,
    run_on_this_machine,
    telemetry_settings,
    world_first,
)
from pitchside.robot import available, simulated_robots
from robot_nodes.catalog import MOTION_NODES, NODES
from robot_nodes.launch import COMPOSE_HELP, NodeProcess, RobotNodes, process_groups
from robot_nodes.runtime.clock import LOCKSTEP, SIM_TIME_ENV
from robot_nodes.sim.lineup import Lineup, LineupError, Team, parse_robots
from server.security.credentials import ENV_TOKEN, new_token
from wire.command_line import CommandParser
from wire.gamecontroller.packets import DATA_PORT, RETURN_PORT

log = logging.getLogger("pitchside.match")
# what every robot of a match runs (cm730: in the world's process); the behaviour's nodes join once they exist
BASE_NODES = [*MOTION_NODES, "walking", "game_controller", "mitecom", "telemetry"]
BEHAVIOUR_NODES = ["head", "kick", "behavior"]
LOOPBACK_BROADCAST = "127.255.255.255"


def default_nodes() -> list[str]:
    """The match's robot nodes: the base ones and those of the behaviour that the catalog has (and can run)."""
    return available([n for n in [*BASE_NODES, *BEHAVIOUR_NODES] if n in NODES])


def parse_nodes(text: str) -> list[str]:
    """``--nodes``: comma-separated catalog names (or a team's own ``package.module[:Class]``)."""
    names = [n.strip() for n in text.split(",") if n.strip()]
    unknown = [n for n in names if n not in NODES and "." not in n]
    if unknown or not names:
        raise ValueError(f"--nodes: {', '.join(unknown) or 'none given'}: not a node of robot_nodes/catalog.py "
                         f"({', '.join(NODES)}) nor a package.module")
    if "cm730" in names:
        raise ValueError("--nodes: cm730 runs in the world's process, one per robot; leave it out")
    return names


@dataclass(frozen=True)
class GameControllerPlan:
    """Where the GameController's packets go and its robots' return packets come back."""

    kind: str  # "sim" or "external"
    port: int  # UDP port the GameController sends to
    return_port: int
    http_port: int | None  # the simulated GameController's HTTP API
    # team number -> the UDP port its team messages are broadcast to on loopback, counted by the simulated
    # GameController (10000 + team number on a field); None: each robot's own port and its teammates as peers
    team_message_ports: dict[int, int] | None = None

    @property
    def listen_address(self) -> str:
        # the simulated GameController broadcasts on loopback: robots bound to its broadcast address hear it and
        # nothing from the network; a real one broadcasts on the field's network, heard on every interface
        return LOOPBACK_BROADCAST if self.kind == "sim" else "0.0.0.0"


def robot_settings(team: Team, player: int, gc: GameControllerPlan, mitecom_ports: dict[str, int],
                   telemetry_port: int, telemetry_key: Path | None, half_s: int = 600) -> dict[str, list[str]]:
    """One robot's settings per node: its team and number for the GameController and team communication."""
    team_talk = ["--set", f"team_id={team.number}", "--set", f"player_id={player}"]
    if gc.team_message_ports is not None:
        # the HSL way, on loopback: broadcast to the team's port, where the simulated GameController counts
        team_talk += ["--set", "hsl=true", "--set", f"team_port={gc.team_message_ports[team.number]}",
                      "--set", f"listen_address={LOOPBACK_BROADCAST}",
                      "--set", f"broadcast_address={LOOPBACK_BROADCAST}", "--set", f"half_s={half_s}"]
    else:
        own = mitecom_ports[team.robot_id(player)]
        mates = ",".join(f"127.0.0.1:{mitecom_ports[r]}" for r in team.robot_ids() if r != team.robot_id(player))
        team_talk += ["--set", "listen_address=127.0.0.1", "--set", f"port={own}"]
        if mates:  # a team of one has nobody to tell (the node's default, its own port, talks to itself)
            team_talk += ["--set", f"peers={mates}"]
    if telemetry_key:  # the run's key: each team signs with its own key derived from it (team number)
        team_talk += ["--set", f"team_key={telemetry_key}"]
    # the stand-in localization gives both teams the world's frame (the dashboard draws both where they are): the
    # away team defends its +x half
    field_side = ["--set", f"own_half={'+x' if team.own_goal > 0 else '-x'}"]
    return {
        "behavior": field_side,
        "head": field_side,
        "game_controller": ["--set", f"team_number={team.number}", "--set", f"player_number={player}",
                            "--set", f"listen_address={gc.listen_address}", "--set", f"listen_port={gc.port}",
                            "--set", f"return_port={gc.return_port}", *field_side],
        "mitecom": team_talk,
        "telemetry": [*telemetry_settings(telemetry_port, telemetry_key),
                      "--set", f"topics={match_telemetry_topics()}"],
    }


# What a match's dashboard gets slower than the telemetry's defaults: 14 robots' telemetry (sender and dashboard) was
# the largest part of a 7 v 7's CPU. The team overview has each robot's HCM state, pose and ball at 10 Hz from the
# overview datagram; the field view keeps position and ball_relative at 10 Hz; joints, IMU, the HCM's state message
# and diagnostics (the 3D view, plots, node health) come at half their lab rates.
MATCH_TELEMETRY_RATES_HZ = {"joint_states": 5.0, "imu/data": 5.0, "robot_state": 5.0, "diagnostics": 0.5}


def match_telemetry_topics() -> str:
    """The telemetry node's ``topics`` in a match: its defaults with MATCH_TELEMETRY_RATES_HZ."""
    from robot_nodes.telemetry.sender import DEFAULT_TOPICS, parse_topics

    rates = parse_topics(DEFAULT_TOPICS) | MATCH_TELEMETRY_RATES_HZ
    return ",".join(f"{name}:{hz:g}" for name, hz in rates.items())


@dataclass(frozen=True)
class MatchPlan:
    lineup: Lineup
    nodes: list[str]
    half_s: int
    ready_s: float
    set_s: float
    initial_s: float
    half_time_s: float
    seed: int
    cameras: int
    compose: str
    model: str
    sim_time: bool = True
    lockstep: bool = True  # with sim_time: the world waits for every robot's nodes each tick
    robots_per_process: int = 1  # with compose "all": that many robots of a team share a process (shared_process)


def match_processes(plan: MatchPlan, *, endpoint: str, http_port: int, dashboard: DashboardPlan,
                    gc: GameControllerPlan,
                    mitecom_ports: dict[str, int], token: str, telemetry_key: Path | None) -> list[NodeProcess]:
    """Every process of the match: the world (with the referee and a simulated GameController), each robot's
    nodes, the dashboard in match mode."""
    lineup = plan.lineup
    world = [sys.executable, "-m", "robot_nodes.sim.match", "--robots",
             f"{lineup.home.players}v{lineup.away.players}", "--teams", str(lineup.home.number),
             str(lineup.away.number), "--gamecontroller", gc.kind, "--gc-port", str(gc.port),
             "--gc-return-port", str(gc.return_port), "--half-seconds", str(plan.half_s),
             "--ready-seconds", str(plan.ready_s), "--set-seconds", str(plan.set_s),
             "--initial-seconds", str(plan.initial_s), "--half-time-seconds", str(plan.half_time_s),
             "--seed", str(plan.seed), "--cameras", str(plan.cameras), "--connect", endpoint,
             "--params", str(descriptions.params_file(plan.model))]
    if plan.sim_time:
        world.append("--sim-time")
        if plan.lockstep:
            world.append("--lockstep")
    if gc.http_port is not None:
        world += ["--gc-http-port", str(gc.http_port)]
    if gc.team_message_ports is not None:
        world += ["--team-message-ports", *(str(gc.team_message_ports[t.number]) for t in lineup.teams)]
    processes = [NodeProcess("world", world)]
    for team in lineup.teams:
        robots = [RobotNodes(team.robot_id(player), plan.nodes,
                             robot_settings(team, player, gc, mitecom_ports, dashboard.robots_port, telemetry_key,
                                            plan.half_s))
                  for player in range(1, team.players + 1)]
        for process in simulated_robots(robots, [endpoint], model=plan.model, compose=plan.compose,
                                        per_process=plan.robots_per_process):
            if plan.sim_time:
                process.env[SIM_TIME_ENV] = LOCKSTEP if plan.lockstep else "1"
            processes.append(process)
    processes += dashboard_processes(dashboard, http_port=http_port, model=plan.model, connect=[], match=True,
                                     token=token, telemetry_key=telemetry_key)
    return world_first(processes, others_nice=ROBOTS_IN_MATCH_NICE)


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(prog="pitchside match", description=__doc__)
    parser.add_argument("--robots", default=None, help="robots per team: 1v1 .. 11v11 (default 2v2)")
    parser.add_argument("--players", type=int, default=None,
                        help="robots per team, the same for both: 4 plays the HSL's Small Foundation (4 v 4), 7 its "
                             "Small Advanced (7 v 7, a goalkeeper and six field players)")
    parser.add_argument("--half-minutes", type=float, default=10.0, help="length of a half (default 10)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the simulation's noise")
    parser.add_argument("--gamecontroller", choices=["sim", "external"], default="sim",
                        help="sim: the simulated GameController referees, on the simulation's clock; external: a "
                             "real GameController on this machine or network (it must broadcast to UDP 3838)")
    parser.add_argument("--teams", type=int, nargs=2, default=[1, 2], metavar=("HOME", "AWAY"),
                        help="team numbers (default 1 2; with an external GameController: as configured there)")
    parser.add_argument("--nodes", default=None,
                        help=f"each robot's nodes, comma-separated (default: {', '.join(BASE_NODES)} and, once in "
                             f"the catalog, {', '.join(BEHAVIOUR_NODES)})")
    parser.add_argument("--compose", default="all", help=COMPOSE_HELP + " (default all: each robot's nodes in one "
                                                                       "process)")
    parser.add_argument("--robots-per-process", type=int, default=ROBOTS_PER_PROCESS,
                        help=f"with --compose all: how many robots of a team share a process (default "
                             f"{ROBOTS_PER_PROCESS}; 1: a process per robot, as on real robots)")
    parser.add_argument("--cameras", type=int, default=0,
                        help="how many robots render head camera images (default 0; every robot still sees the "
                             "ball, goals and robots through the perception stand-ins)")
    parser.add_argument("--ready-seconds", type=float, default=45.0, help="READY's time limit (the rules: 45)")
    parser.add_argument("--set-seconds", type=float, default=5.0, help="SET before PLAYING")
    parser.add_argument("--initial-seconds", type=float, default=5.0, help="INITIAL before READY")
    parser.add_argument("--half-time-seconds", type=float, default=30.0, help="the half-time break")
    parser.add_argument("--port", type=int, default=8080, help="dashboard port (a free one if taken)")
    parser.add_argument("--gc-port", type=int, default=None,
                        help=f"UDP port the GameController sends to (default {DATA_PORT}; for the simulated one a "
                             "port the kernel has free)")
    parser.add_argument("--gc-return-port", type=int, default=None,
                        help=f"external: the UDP port the GameController hears return packets on (default "
                             f"{RETURN_PORT})")
    parser.add_argument("--model", default="minibot")
    parser.add_argument("--wall-clock", action="store_true",
                        help="the robots' nodes run on the wall clock instead of the simulation's (a world that falls "
                             "behind real time then breaks walking and get-ups instead of slowing the game)")
    parser.add_argument("--no-lockstep", action="store_true",
                        help="the world keeps its own pace instead of waiting for every robot's nodes each 10 ms of "
                             "simulated time: on a machine short of CPU their control then lags behind the physics "
                             "and they fall more, as robots with too slow a computer would")
    args = parser.parse_args(argv)
    if args.players is not None and args.robots is not None:
        parser.error("give --players N (N v N) or --robots NvM, not both")
    robots_text = f"{args.players}v{args.players}" if args.players is not None else args.robots or "2v2"
    try:
        lineup = Lineup.of((args.teams[0], args.teams[1]), parse_robots(robots_text))
        nodes = parse_nodes(args.nodes) if args.nodes else default_nodes()
        process_groups(nodes, args.compose)
    except (LineupError, ValueError) as exc:
        parser.error(str(exc))
    if args.robots_per_process < 1:
        parser.error("--robots-per-process must be at least 1")
    if not 0 < args.half_minutes <= 60 or not math.isfinite(args.half_minutes):
        parser.error(f"--half-minutes must be in (0, 60], got {args.half_minutes}")
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s [match] %(message)s")
    plan = MatchPlan(lineup, nodes, max(1, round(args.half_minutes * 60)), args.ready_seconds, args.set_seconds,
                     args.initial_seconds, args.half_time_seconds, args.seed, args.cameras, args.compose, args.model,
                     sim_time=not args.wall_clock, lockstep=not (args.wall_clock or args.no_lockstep),
                     robots_per_process=args.robots_per_process)
    endpoint = f"tcp/127.0.0.1:{free_port(7447)}"
    http_port = free_port(args.port)
    dashboard = DashboardPlan.fresh()  # ports inside the run: the kernel's free ones (local_run.kernel_port)
    robots = lineup.robot_ids()
    mitecom_ports = dict(zip(robots, kernel_ports(len(robots)), strict=True))
    if args.gamecontroller == "sim":
        home_port, away_port = kernel_ports(2)
        gc = GameControllerPlan("sim", args.gc_port or kernel_port(), kernel_port(), free_port(8038),
                                {lineup.home.number: home_port, lineup.away.number: away_port})
        where = f"GameController http://127.0.0.1:{gc.http_port}/status"
    else:
        gc = GameControllerPlan("external", args.gc_port or DATA_PORT, args.gc_return_port or RETURN_PORT, None)
        where = f"listening for the GameController on UDP {gc.port}"
    token = os.environ.get(ENV_TOKEN) or new_token()
    run_on_this_machine("match", endpoint, http_port, token, lambda key: match_processes(
        plan, endpoint=endpoint, http_port=http_port, dashboard=dashboard, gc=gc, mitecom_ports=mitecom_ports,
        token=token, telemetry_key=key), also=where, dashboard=dashboard)


if __name__ == "__main__":
    main()
