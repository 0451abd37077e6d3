"""A multi-robot simulation in one process: ``python -m robot_nodes.cm730.sim --robots 3``.

One SimWorld with robots robot1..robotN, one SimRunner stepping it, and one cm730 node per robot, all on
one Zenoh session; each node serves its robot's topics (pitchside/robotK/...) exactly as a standalone
``python -m robot_nodes.cm730 --robot-id robotK`` would.
"""

from __future__ import annotations

import logging
import signal
import threading
from pathlib import Path

from robot_nodes.cm730.node import Cm730Node
from robot_nodes.cm730.sim import SimRunner, SimWorld
from robot_nodes.cm730.sim_backend import MujocoBackend
from robot_nodes.runtime import BusConfig, Node, open_session
from robot_nodes.runtime.node import parse_overrides
from wire.bus import add_bus_arguments, bus_from_arguments
from wire.command_line import CommandParser


def serve(n_robots: int, bus: BusConfig, params: Path | None = None, overrides: dict | None = None,
          real_time_factor: float = 1.0) -> tuple[SimRunner, list[Node], object]:
    """Starts the world and its nodes; returns (runner, nodes, session) for the caller to stop."""
    world = SimWorld(n_robots=n_robots)
    runner = SimRunner(world, real_time_factor).start()
    session = open_session(bus)
    overrides = dict(overrides or {})
    overrides.setdefault("real_time_factor", real_time_factor)
    nodes = [Cm730Node(robot_id=r.robot_id, bus=session, params_file=params, overrides=overrides,
                       backend=MujocoBackend(world, r, runner)).start() for r in world.robots]
    return runner, nodes, session


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, default=1)
    add_bus_arguments(parser)
    parser.add_argument("--params", type=Path, default=None)
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    parser.add_argument("--real-time-factor", type=float, default=1.0, help="0 = as fast as possible")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s [sim] %(message)s")
    bus = bus_from_arguments(args)
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    runner, nodes, session = serve(args.robots, bus, args.params, parse_overrides(args.set), args.real_time_factor)
    logging.info("simulating %d robot(s): %s", len(nodes), ", ".join(n.robot_id for n in nodes))
    stop.wait()
    for node in nodes:
        node.shutdown()
    runner.stop()
    session.close()  # type: ignore[attr-defined]


if __name__ == "__main__":
    main()
