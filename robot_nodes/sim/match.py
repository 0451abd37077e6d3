"""The world of a simulated match in one process: ``python -m robot_nodes.sim.match --robots 2v2 ...``.

Two teams in one MuJoCo world (home1..homeN defend -x, away1..awayM defend +x), a cm730 node per robot (as
``python -m robot_nodes.sim`` serves them), the referee on the physics thread, and the GameController: the
simulated one on the world's clock (``--gamecontroller sim``: it broadcasts to the robots on this machine, the
referee whistles to it, its HTTP API on ``--gc-http-port``), or a real one on the network (``external``: the
referee listens to its broadcasts like a robot and only says what the human at the GameController should press).
"""

from __future__ import annotations

import logging
import signal
import threading
from pathlib import Path

from robot_nodes.runtime.node import parse_overrides
from robot_nodes.sim.__main__ import serve_world
from robot_nodes.sim.gamecontroller import SimulatedGame, SimulatedGameController
from robot_nodes.sim.gamecontroller_listener import GameControllerListener
from robot_nodes.sim.lineup import Lineup, LineupError, parse_robots
from robot_nodes.sim.placements import lineup_start
from robot_nodes.sim.referee import LoggingWhistle, Referee, RefereeRules
from robot_nodes.sim.world import SimWorld
from wire.bus import add_bus_arguments, bus_from_arguments
from wire.command_line import CommandParser
from wire.gamecontroller.packets import DATA_PORT, RETURN_PORT
from wire.heap import freeze_startup_heap

log = logging.getLogger("pitchside.match_world")
LOOPBACK_BROADCAST = "127.255.255.255"  # every socket of this machine bound to the port hears it, nothing else


def simulated_game(lineup: Lineup, half_s: int, ready_s: float = 45.0, set_s: float = 5.0, initial_s: float = 5.0,
                   half_time_s: float = 30.0, colours: tuple[int, int] = (0, 1)) -> SimulatedGame:
    """The game the simulated GameController runs for this lineup."""
    return SimulatedGame(teams=(lineup.home.number, lineup.away.number), team_colors=colours,
                         players_per_team=max(lineup.home.players, lineup.away.players), initial_s=initial_s,
                         ready_s=ready_s, set_s=set_s, half_s=half_s, half_time_s=half_time_s,
                         wait_for_players=(lineup.home.players, lineup.away.players))


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", default="2v2", help="robots per team, e.g. 2v2 or 4v4 (default 2v2)")
    parser.add_argument("--teams", type=int, nargs=2, default=[1, 2], metavar=("HOME", "AWAY"),
                        help="GameController team numbers (default 1 2)")
    parser.add_argument("--gamecontroller", choices=["sim", "external"], default="sim")
    parser.add_argument("--gc-port", type=int, default=DATA_PORT, help="UDP port the GameController sends to")
    parser.add_argument("--gc-return-port", type=int, default=RETURN_PORT,
                        help="sim: UDP port (on 127.0.0.1) for the robots' return packets")
    parser.add_argument("--gc-http-port", type=int, default=None, help="sim: the GameController's HTTP API here")
    parser.add_argument("--team-message-ports", type=int, nargs=2, default=None, metavar=("HOME", "AWAY"),
                        help="sim: count each team's messages broadcast on loopback to these UDP ports against its "
                             "budget (10000 + team number on a field)")
    parser.add_argument("--half-seconds", type=int, default=600)
    parser.add_argument("--ready-seconds", type=float, default=45.0)
    parser.add_argument("--set-seconds", type=float, default=5.0)
    parser.add_argument("--initial-seconds", type=float, default=5.0)
    parser.add_argument("--half-time-seconds", type=float, default=30.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--cameras", type=int, default=0, help="how many robots render head camera images")
    parser.add_argument("--sim-time", action="store_true",
                        help="send the world's time on each robot's clock topic for nodes that follow it "
                             "(PITCHSIDE_SIM_TIME=1); this world's cm730 nodes follow it too")
    parser.add_argument("--lockstep", action="store_true",
                        help="with --sim-time: wait each tick for the robots' nodes (PITCHSIDE_SIM_TIME=lockstep)")
    add_bus_arguments(parser)
    parser.add_argument("--params", type=Path, default=None)
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", help="cm730 parameters")
    args = parser.parse_args(argv)
    try:
        lineup = Lineup.of((args.teams[0], args.teams[1]), parse_robots(args.robots))
    except LineupError as exc:
        parser.error(str(exc))
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s [match world] %(message)s")
    world = SimWorld(lineup=lineup, placements=lineup_start(lineup), seed=args.seed)
    served = serve_world(world, bus_from_arguments(args), args.params, parse_overrides(args.set),
                         cameras=args.cameras, sim_time=args.sim_time, lockstep=args.lockstep)
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    gc: SimulatedGameController | None = None
    listener: GameControllerListener | None = None
    try:
        if args.gamecontroller == "sim":
            game = simulated_game(lineup, args.half_seconds, args.ready_seconds, args.set_seconds,
                                  args.initial_seconds, args.half_time_seconds)
            ports = args.team_message_ports
            gc = SimulatedGameController(
                game, [(LOOPBACK_BROADCAST, args.gc_port)], ("127.0.0.1", args.gc_return_port),
                clock=lambda: world.time, team_message_address=LOOPBACK_BROADCAST if ports else None,
                team_message_ports={lineup.home.number: ports[0], lineup.away.number: ports[1]} if ports else None,
            ).start()
            if args.gc_http_port is not None:
                log.info("GameController HTTP API on http://127.0.0.1:%d/status", gc.serve_http(args.gc_http_port))
            Referee(world, lineup, gc.snapshot, gc).attach(served.runner)
        else:
            listener = GameControllerListener("0.0.0.0", args.gc_port, (lineup.home.number, lineup.away.number))
            Referee(world, lineup, listener.latest, LoggingWhistle(), RefereeRules()).attach(served.runner)
        log.info("match %s: team %d (%s) against team %d (%s), refereed by the %s GameController", args.robots,
                 lineup.home.number, ", ".join(lineup.home.robot_ids()), lineup.away.number,
                 ", ".join(lineup.away.robot_ids()), "simulated" if args.gamecontroller == "sim" else "external")
        freeze_startup_heap()
        stop.wait()
    finally:
        if gc is not None:
            gc.stop()
        if listener is not None:
            listener.close()
        served.close()


if __name__ == "__main__":
    main()
