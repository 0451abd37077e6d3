"""A multi-robot simulation in one process: ``python -m robot_nodes.sim --robots 3``.

One SimWorld with robots robot1..robotN, one SimRunner stepping it, and one cm730 node per robot, all on
one Zenoh session; each node serves its robot's topics (/robotK/... in rmw_zenoh's keys) exactly as a standalone
``python -m robot_nodes.cm730 --robot-id robotK`` would.
"""

from __future__ import annotations

import logging
import signal
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from robot_nodes.cm730.node import Cm730Node
from robot_nodes.cm730.sim_backend import MujocoBackend
from robot_nodes.runtime import BusConfig, Node, open_session
from robot_nodes.runtime.clock import CLOCK_PERIOD_S, WALL_CLOCK
from robot_nodes.runtime.node import parse_overrides
from robot_nodes.runtime.one_loop import NodesOnOneLoop
from robot_nodes.sim.runner import SimRunner
from robot_nodes.sim.world import SimWorld
from robot_nodes.sim.world_clock import WorldClock
from wire.bus import add_bus_arguments, bus_from_arguments
from wire.command_line import CommandParser
from wire.heap import freeze_startup_heap


def robot_overrides(index: int, overrides: dict[str, Any], cameras: int) -> dict[str, Any]:
    """A robot's cm730 settings in a shared world: the first robot's node alone sends the ground truth (every
    robot's pose is in it), and only the first ``cameras`` robots render their head camera (perception, the
    detections and relative positions, runs for all)."""
    own = dict(overrides)
    if index > 0:
        own["ground_truth_rate"] = 0.0
    if index >= cameras:
        own["render_camera"] = False
    return own


@dataclass
class ServedWorld:
    """A world being stepped and served: its runner, one cm730 node per robot (on one loop), their Zenoh session."""

    runner: SimRunner
    nodes: list[Node]
    session: Any
    loop: NodesOnOneLoop
    clock: WorldClock | None = None

    def close(self) -> None:
        self.loop.shutdown()
        self.runner.stop()
        if self.clock is not None:
            self.clock.close()
        self.session.close()


def serve(n_robots: int, bus: BusConfig, params: Path | None = None, overrides: dict | None = None,
          real_time_factor: float = 1.0, cameras: int | None = None, sim_time: bool = False,
          lockstep: bool = False) -> ServedWorld:
    """Starts a world of ``n_robots`` and its nodes, for the caller to close. cameras: how many robots render
    images (default all)."""
    return serve_world(SimWorld(n_robots=n_robots), bus, params, overrides, real_time_factor, cameras, sim_time,
                       lockstep)


def serve_world(world: SimWorld, bus: BusConfig, params: Path | None = None, overrides: dict | None = None,
                real_time_factor: float = 1.0, cameras: int | None = None, sim_time: bool = False,
                lockstep: bool = False) -> ServedWorld:
    """A runner stepping ``world`` and one cm730 node per robot, on one Zenoh session. sim_time: the world sends
    its time on every robot's ``clock`` topic and its cm730 nodes follow it, as the robots' nodes do when they
    run with PITCHSIDE_SIM_TIME (robot_nodes/runtime/clock.py). lockstep (with sim_time): each tick the world
    waits until every robot process that answers on ``clock_done`` (PITCHSIDE_SIM_TIME=lockstep) has done its work
    on the tick before and its nodes took the motor goals, which then go to the servos, then until its cm730
    nodes have sent the sensors of the new time (WorldClock: a tick of delay, as on a servo bus)."""
    in_lockstep = sim_time and lockstep
    world.hold_gil = in_lockstep  # its physics is on every tick's critical path: it never waits for the GIL
    runner = SimRunner(world, real_time_factor).start(short_switch=not in_lockstep)
    session = open_session(bus)
    overrides = dict(overrides or {})
    overrides.setdefault("real_time_factor", real_time_factor)
    cameras = len(world.robots) if cameras is None else cameras
    world_clock = None
    if sim_time:
        if lockstep:
            world.hold_changes()  # the motor goals of a tick reach the servos when the clock says (WorldClock)
        world_clock = WorldClock(session, [r.robot_id for r in world.robots], lockstep,
                                 goals_due=world.release_changes if lockstep else None)
    if world_clock is not None:
        world_clock.clock.advance(world.time)
        runner.tick_clock(CLOCK_PERIOD_S, world_clock.tick)
        if in_lockstep:
            runner.slowest_ticks = world_clock.slowest
    # the robots' cm730 nodes share one loop thread: each tick is short (well under a millisecond), and with 8
    # robots one thread cost a tenth of a core less than eight (robot_nodes/runtime/one_loop.py)
    clock = world_clock.clock if world_clock else None
    group = NodesOnOneLoop("world", clock or WALL_CLOCK)
    nodes: list[Node] = [group.add(Cm730Node(robot_id=r.robot_id, bus=session, params_file=params,
                                             overrides=robot_overrides(i, overrides, cameras),
                                             backend=MujocoBackend(world, r, runner), clock=clock, loop=group.loop))
                         for i, r in enumerate(world.robots)]
    group.start()
    return ServedWorld(runner, nodes, session, group, world_clock)


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, default=1)
    add_bus_arguments(parser)
    parser.add_argument("--params", type=Path, default=None)
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    parser.add_argument("--real-time-factor", type=float, default=1.0, help="0 = as fast as possible")
    parser.add_argument("--cameras", type=int, default=None,
                        help="how many robots (the first ones) render their head camera images (default all); "
                             "the others still see the ball, goals and robots (detections, relative positions)")
    parser.add_argument("--sim-time", action="store_true",
                        help="send the world's time on each robot's clock topic, for robots whose nodes run with "
                             "PITCHSIDE_SIM_TIME=1 (this world's cm730 nodes follow it too)")
    parser.add_argument("--lockstep", action="store_true",
                        help="with --sim-time: wait each tick for the robots' nodes that run with "
                             "PITCHSIDE_SIM_TIME=lockstep")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s [sim] %(message)s")
    bus = bus_from_arguments(args)
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    served = serve(args.robots, bus, args.params, parse_overrides(args.set), args.real_time_factor, args.cameras,
                   args.sim_time, args.lockstep)
    logging.info("simulating %d robot(s): %s", len(served.nodes), ", ".join(n.robot_id for n in served.nodes))
    freeze_startup_heap()
    stop.wait()
    served.close()


if __name__ == "__main__":
    main()
