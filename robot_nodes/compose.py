"""Several nodes of one robot in one process, what ROS 2 calls a component container:

    python -m robot_nodes.compose --robot-id robot1 hcm animation walking --set walking.rate_hz=100

Several robots' nodes can share the process too, each robot's after a ``+`` (one Zenoh session for all, a loop
thread per robot, so one robot's callbacks never wait for another's):

    python -m robot_nodes.compose --robot-id robot1 hcm walking + --robot-id robot2 hcm walking --set hcm.rate_hz=50

That is what a simulated team on one laptop wants: what a robot's nodes cost is mostly the hand-over of every
100 Hz sensor message from the world's process (Zenoh's threads waking, once per message and process), and the world
sends each tick's messages of all robots of a process in one go (bench/team.py). A real robot runs its own.

Each node keeps its name, its parameters (queryable as when it runs alone), its timers and its diagnostics. They
share the process's Zenoh session, so what one publishes reaches the others as the same object, without CDR
(robot_nodes/runtime/local_bus.py), and one loop thread (robot_nodes/runtime/one_loop.py): a robot's nodes wake
together at each 100 Hz tick, and a thread each spent more on handing the interpreter over than on the work. The
bound that makes it safe: no callback of these nodes blocks (sockets, speech and files have threads of their own),
so a node waits at most for the other nodes' callbacks due at the same time; each node's diagnostics say the
loop's longest callback of each second (``loop_longest_call_ms``). ``--loop-per-node`` gives each node a loop
thread of its own instead, for a node whose callbacks may take long; ``--one-loop`` puts the nodes of all robots of
the process on one loop (a simulated team on the wall clock: the same bound, over the robots' nodes together; on
simulated time each robot keeps its loop, as each follows its own robot's clock).

A node that cannot start, or whose loop ends on its own, ends the process with exit code FAILED_NODE_EXIT + its
index, so the supervisor (robot_nodes/launch.py) names the node when it restarts the process.
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading
import time
from pathlib import Path
from typing import Any

from robot_nodes.catalog import FAILED_NODE_EXIT, NODES, ROBOT_SEPARATOR, entry, node_label
from robot_nodes.runtime import Node
from robot_nodes.runtime.clock import sim_time_wanted
from robot_nodes.runtime.node import parse_overrides
from robot_nodes.runtime.one_loop import NodesOnOneLoop
from wire.bus import add_bus_arguments, bus_from_arguments, load_config_file, open_session
from wire.command_line import CommandParser
from wire.heap import freeze_startup_heap

log = logging.getLogger("pitchside.compose")

MAX_NODES = 255 - FAILED_NODE_EXIT  # of one process, robots together: each failure must have an exit code
SHUTDOWN_WAIT_S = 10.0  # per stage of a clean stop (nodes with last duties first, then the others)


def overrides_by_node(items: list[str], nodes: list[tuple[str, type[Node]]]) -> dict[str, dict[str, Any]]:
    """``--set NODE.NAME=VALUE`` -> {node: {name: value}}, NODE as given on the command line or the node's own name;
    SystemExit names the nodes of the process for an entry that fits none."""
    out: dict[str, dict[str, Any]] = {spec: {} for spec, _ in nodes}
    aliases = {alias: spec for spec, cls in nodes for alias in (spec, node_label(spec), cls.name)}
    for item in items:
        target, dot, rest = item.partition(".")
        if not dot or target not in aliases or "=" not in rest:
            raise SystemExit(f"compose: --set expects NODE.NAME=VALUE with NODE one of "
                             f"{', '.join(sorted(aliases))}, got {item!r}")
        out[aliases[target]].update(parse_overrides([rest]))
    return out


def load_classes(names: list[str], robot_id: str, first: int = 0) -> list[tuple[str, type[Node]]]:
    """The node classes; one that does not load ends the process, naming it (first: the index of names[0] among
    the nodes of the process, robots before included)."""
    out = []
    for i, name in enumerate(names):
        try:
            out.append((name, entry(name).load()))
        except Exception as exc:
            log.critical("%s/%s cannot be loaded: %s: %s", robot_id, node_label(name), type(exc).__name__, exc)
            raise SystemExit(FAILED_NODE_EXIT + first + i) from exc
    return out


def split_robots(argv: list[str]) -> list[list[str]]:
    """The command line cut at each ``+``: the first robot's arguments (with the process's own), then each further
    robot's."""
    robots: list[list[str]] = [[]]
    for arg in argv:
        if arg == ROBOT_SEPARATOR:
            robots.append([])
        else:
            robots[-1].append(arg)
    return robots


class ComposedNodes:
    """The nodes of one process, built in order on one session (each robot's on one loop, ``groups``, or a loop
    each), stopped with their last duties first."""

    def __init__(self, nodes: list[Node], groups: list[NodesOnOneLoop] | None = None) -> None:
        self.nodes = nodes
        self.groups = groups or []
        self.stopping = threading.Event()

    def start(self) -> None:
        for group in self.groups:
            group.start()
        if not self.groups:
            for node in self.nodes:
                node.start()

    def failed(self) -> int | None:
        """Index of a node that stopped while nobody asked it to (its loop ended, or it left the shared one)."""
        if self.stopping.is_set():
            return None
        for group in self.groups:
            if not group.running:
                culprit = group.failed
                return next((i for i, node in enumerate(self.nodes) if node is culprit),
                            self.nodes.index(group.nodes[0]) if group.nodes else 0)
        for i, node in enumerate(self.nodes):
            thread = node._thread
            if node.closed or (thread is not None and not thread.is_alive()):
                return i
        return None

    def stop(self) -> None:
        """Nodes with last duties (the HCM sits the robot down) stop first, while the nodes they need still run."""
        self.stopping.set()
        with_duties = [n for n in self.nodes if type(n).request_shutdown is not Node.request_shutdown]
        for stage in (with_duties, [n for n in self.nodes if n not in with_duties]):
            for node in stage:
                node.loop.call_soon(node.request_shutdown)
            deadline = time.monotonic() + SHUTDOWN_WAIT_S
            for node in stage:
                if not node.wait_closed(max(0.1, deadline - time.monotonic())):
                    log.warning("%s did not stop within %.0f s", node.name, SHUTDOWN_WAIT_S)
                if node._thread is not None:
                    node._thread.join(max(0.1, deadline - time.monotonic()))
        for group in self.groups:
            group.shutdown()


def build(classes: list[tuple[str, type[Node]]], robot_id: str, session: Any, params: Path | None,
          overrides: dict[str, dict[str, Any]], group: NodesOnOneLoop | None = None, first: int = 0) -> list[Node]:
    """Each node on the shared session (and ``group``'s loop), in the order given; a node that cannot start ends
    the process, naming it (first: as in load_classes). The caller shuts down what other robots built."""
    nodes: list[Node] = []
    for i, (name, cls) in enumerate(classes):
        try:
            node = cls(robot_id=robot_id, bus=session, params_file=params, overrides=overrides[name],
                       loop=group.loop if group is not None else None,
                       clock=group.loop.clock if group is not None and group.loop.clock.simulated else None)
        except Exception as exc:
            log.critical("%s/%s failed to start: %s: %s", robot_id, node_label(name), type(exc).__name__, exc)
            for node in nodes:
                node.shutdown()
            if group is not None:
                group.shutdown()
            raise SystemExit(FAILED_NODE_EXIT + first + i) from exc
        nodes.append(group.add(node) if group is not None else node)
    return nodes


def robot_parser(prog: str, description: str | None) -> CommandParser:
    """The arguments of one robot of the process (the first robot's parser adds the process's own)."""
    parser = CommandParser(prog=prog, description=description, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("nodes", nargs="+", help=f"nodes of this process: {', '.join(NODES)}, or a team's own "
                                                 "as package.module:NodeClass")
    parser.add_argument("--robot-id", default="robot1")
    parser.add_argument("--params", type=Path, default=None, help="params.yaml of the robot")
    parser.add_argument("--set", action="append", default=[], metavar="NODE.NAME=VALUE",
                        help="override a node's parameter (YAML value syntax)")
    return parser


def parse_robots(parser: CommandParser, argv: list[str]) -> tuple[argparse.Namespace, list[argparse.Namespace]]:
    """The process's arguments (the first robot's with them) and each robot's; SystemExit for a robot named twice, a
    node named twice for one robot, or more nodes than exit codes."""
    first, *more = split_robots(argv)
    args = parser.parse_args(first)
    further = robot_parser(f"{parser.prog} ... {ROBOT_SEPARATOR}", None)
    robots = [args, *(further.parse_args(robot) for robot in more)]
    ids = [robot.robot_id for robot in robots]
    if len(set(ids)) != len(ids):
        raise SystemExit(f"compose: a robot is named twice in {ids}")
    for robot in robots:
        if len(set(robot.nodes)) != len(robot.nodes):
            raise SystemExit(f"compose: a node is named twice in {robot.nodes} of {robot.robot_id}")
    if sum(len(robot.nodes) for robot in robots) > MAX_NODES:
        raise SystemExit(f"compose: at most {MAX_NODES} nodes in one process (each failure has its exit code)")
    return args, robots


def main(argv: list[str] | None = None) -> None:
    parser = robot_parser("python -m robot_nodes.compose", __doc__)
    add_bus_arguments(parser)
    parser.add_argument("--loop-per-node", action="store_true",
                        help="a loop thread for each node instead of one per robot (for a node whose callbacks may "
                             "take long)")
    parser.add_argument("--one-loop", action="store_true",
                        help="one loop thread for the nodes of all robots of the process (on simulated time they "
                             "follow the first robot's clock: the robots of one process share a world)")
    parser.add_argument("--log-level", default="INFO")
    args, robots = parse_robots(parser, list(sys.argv[1:] if argv is None else argv))
    logging.basicConfig(level=args.log_level, format="%(asctime)s %(levelname)s [%(name)s] %(message)s")
    plans, first = [], 0
    for robot in robots:
        classes = load_classes(robot.nodes, robot.robot_id, first)
        plans.append((robot, classes, overrides_by_node(robot.set, classes), first))
        first += len(classes)
    if args.zenoh_config:
        try:
            load_config_file(args.zenoh_config)
        except ValueError as exc:
            raise SystemExit(f"compose: {exc}") from None
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    session = open_session(bus_from_arguments(args))
    nodes: list[Node] = []
    groups: list[NodesOnOneLoop] = []
    robot_of: list[str] = []
    shared = None
    if args.one_loop and not args.loop_per_node:
        shared = NodesOnOneLoop.of_process(session, "+".join(robot.robot_id for robot in robots),
                                           robots[0].robot_id if sim_time_wanted() else None)
    try:
        for robot, classes, overrides, first in plans:
            group = shared or (None if args.loop_per_node else NodesOnOneLoop.of_robot(session, robot.robot_id))
            nodes += build(classes, robot.robot_id, session, robot.params, overrides, group, first)
            groups += [group] if group is not None and group not in groups else []
            robot_of += [robot.robot_id] * len(classes)
    except SystemExit:  # the robots built before the one that failed go too (they never started)
        for built in groups or nodes:
            built.shutdown()
        session.close()
        raise
    composed = ComposedNodes(nodes, groups)
    composed.start()
    freeze_startup_heap()
    for robot in robots:
        log.info("%s up for robot %s in one process", ", ".join(n.name for n, r in zip(nodes, robot_of, strict=True)
                                                             if r == robot.robot_id), robot.robot_id)
    failed = None
    while not stop.wait(0.5) and failed is None:
        failed = composed.failed()
    if failed is not None:
        log.critical("%s/%s stopped on its own; ending the process so it is started again", robot_of[failed],
                     composed.nodes[failed].name)
    composed.stop()
    session.close()
    if failed is not None:
        sys.exit(FAILED_NODE_EXIT + failed)


if __name__ == "__main__":
    main()
