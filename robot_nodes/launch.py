"""Starts a robot's nodes as supervised processes: a process that dies is restarted, and why is logged.

    python -m robot_nodes.launch --robot-id robot1 cm730 hcm animation walking --compose all --alone cm730

Each node runs alone as ``python -m <module> --robot-id ... --connect ...``, or with others of its robot in one
process (``--compose``: robot_nodes/compose.py); Ctrl-C (SIGINT) or SIGTERM stops all.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from robot_nodes.catalog import FAILED_NODE_EXIT, NODE_MODULES, NODES, ROBOT_SEPARATOR, node_label
from wire.bus import add_bus_arguments, bus_from_arguments
from wire.command_line import CommandParser
from wire.machine_router import is_router_config, remote, start_machine_router

log = logging.getLogger("pitchside.launch")

@dataclass
class NodeProcess:
    """One supervised node: how to start it and what became of it."""

    name: str
    argv: list[str]
    restart: bool = True
    process: subprocess.Popen[bytes] | None = None
    restarts: int = 0
    last_exit: str = ""
    started_at: float = 0.0
    env: dict[str, str] = field(default_factory=dict)
    restart_at: float | None = None  # dead, to be started again at this time (monotonic)
    given_up: bool = False  # dead and not to be restarted
    members: list[str] = field(default_factory=list)  # the nodes of a composed process, in its order
    nice: int = 0  # added to the launcher's niceness: a lower CPU priority (`nice -n`; raising it needs no root)
    start_delay_s: float = 0.0  # the first start waits this long (a warm spare: after the others have started)

    def start(self) -> None:
        env = {**os.environ, **self.env}
        argv = ["nice", "-n", str(self.nice), *self.argv] if self.nice else self.argv  # nice execs: same pid
        self.process = subprocess.Popen(argv, env=env)
        self.started_at = time.monotonic()
        log.info("started %s (pid %d)", self.name, self.process.pid)

    @property
    def pid(self) -> int | None:
        return self.process.pid if self.process is not None else None


def describe_exit(code: int, members: list[str] | None = None) -> str:
    """How a process ended; for a composed one, which of its nodes failed when it said so."""
    if members and FAILED_NODE_EXIT <= code < FAILED_NODE_EXIT + len(members):
        return f"exited because its node {members[code - FAILED_NODE_EXIT]} failed"
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exited with code {code}"


class Launcher:
    """Keeps a set of node processes alive until stopped.

    A node that dies is started again after ``restart_delay``, or after a back-off doubling up to ``max_delay``
    while it keeps dying within 5 s of its start. Each node waits on its own: a node in back-off never holds up
    the restart of another (an HCM that dies is back at once even while a broken speaker waits its 5 s).
    """

    def __init__(self, nodes: list[NodeProcess], restart_delay: float = 0.2, max_delay: float = 5.0) -> None:
        self.nodes = nodes
        self.restart_delay = restart_delay
        self.max_delay = max_delay
        self._stop = threading.Event()

    def run(self) -> None:
        for node in self.nodes:
            if node.start_delay_s > 0:
                node.restart_at = time.monotonic() + node.start_delay_s
            else:
                node.start()
        try:
            while not self._stop.wait(0.05):
                for node in self.nodes:
                    self._check(node)
        finally:
            self._terminate_all()

    def stop(self) -> None:
        self._stop.set()

    def _check(self, node: NodeProcess) -> None:
        if node.given_up:
            return
        if node.restart_at is not None:
            if time.monotonic() >= node.restart_at:
                node.restart_at = None
                node.start()
            return
        assert node.process is not None
        code = node.process.poll()
        if code is None:
            return
        node.last_exit = describe_exit(code, node.members)
        if not node.restart:
            node.given_up = True
            log.warning("%s %s; not restarting", node.name, node.last_exit)
            return
        # back off when a node dies right after starting, so a broken node does not spin the CPU
        lived = time.monotonic() - node.started_at
        delay = self.restart_delay if lived > 5.0 else min(self.max_delay, self.restart_delay * 2 ** node.restarts)
        log.error("%s (pid %d) %s after %.1f s; restarting in %.1f s", node.name, node.process.pid,
                  node.last_exit, lived, delay)
        node.restarts = 0 if lived > 5.0 else node.restarts + 1
        node.restart_at = time.monotonic() + delay

    def _terminate_all(self) -> None:
        running = [n.process for n in self.nodes if n.process is not None and n.process.poll() is None]
        for proc in running:
            proc.send_signal(signal.SIGTERM)
        deadline = time.monotonic() + 5.0
        for proc in running:
            try:
                proc.wait(max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                log.warning("pid %d did not stop within 5 s; killing it", proc.pid)
                proc.kill()
                proc.wait()


def node_command(module: str, robot_id: str, connect: list[str], params: Path | None = None,
                 extra: list[str] | None = None, zenoh_config: str | Path | None = None,
                 mode: str = "auto") -> list[str]:
    """The node's command line; a Zenoh config file (of a peer or a client) wins over connect."""
    argv = [sys.executable, "-m", module, "--robot-id", robot_id]
    for endpoint in connect:
        argv += ["--connect", endpoint]
    if mode != "auto":
        argv += ["--mode", mode]
    if zenoh_config is not None:
        argv += ["--zenoh-config", str(Path(zenoh_config).resolve())]  # the node may run in another folder
    if params is not None:
        argv += ["--params", str(params)]
    return argv + (extra or [])


COMPOSE_HELP = ("which nodes share a process: 'none' (each alone), 'all' (one process), or groups like "
                "'hcm+animation+walking,speaker+pause' (nodes in no group run alone)")


def process_groups(names: list[str], compose: str = "all", alone: list[str] | None = None) -> list[list[str]]:
    """The nodes of each process, in the order given; ValueError for a group naming a node not started."""
    alone = alone or []
    if compose == "none":
        return [[n] for n in names]
    if compose == "all":
        together = [n for n in names if n not in alone]
        return ([together] if together else []) + [[n] for n in names if n in alone]
    groups = [[n.strip() for n in group.split("+") if n.strip()] for group in compose.split(",") if group.strip()]
    grouped = [n for group in groups for n in group]
    unknown = [n for n in grouped if n not in names]
    if unknown or len(set(grouped)) != len(grouped):
        raise ValueError(f"--compose {compose!r}: every node of a group must be started, and in one group only "
                         f"(started: {', '.join(names)})")
    return [g for g in groups if g] + [[n] for n in names if n not in grouped]


def _composed_sets(name: str, extra: list[str]) -> list[str]:
    """A node's own ``--set NAME=VALUE`` arguments as the composed process takes them (``--set NODE.NAME=VALUE``)."""
    if len(extra) % 2 or any(flag != "--set" for flag in extra[::2]):
        raise ValueError(f"{name}: only --set NAME=VALUE can be passed to a composed node, got {extra}")
    return [a for value in extra[1::2] for a in ("--set", f"{node_label(name)}.{value}")]  # a module has dots


def robot_processes(robot_id: str, groups: list[list[str]], connect: list[str], *, params: Path | None = None,
                    extra: dict[str, list[str]] | None = None, zenoh_config: str | Path | None = None,
                    mode: str = "auto") -> list[NodeProcess]:
    """One supervised process per group: a node alone as ``python -m <module>``, several as robot_nodes.compose;
    extra[name] adds arguments to that node."""
    extra = extra or {}
    processes = []
    for group in groups:
        if len(group) == 1:
            name = group[0]
            argv = node_command(NODE_MODULES.get(name, name), robot_id, connect, params, extra.get(name),
                                zenoh_config, mode)
            processes.append(NodeProcess(f"{robot_id}/{node_label(name)}", argv))
            continue
        argv = node_command("robot_nodes.compose", robot_id, connect, params, _composed_args(group, extra),
                            zenoh_config, mode)
        labels = [node_label(n) for n in group]
        processes.append(NodeProcess(f"{robot_id}/{'+'.join(labels)}", argv, members=labels))
    return processes


def _composed_args(group: list[str], extra: dict[str, list[str]]) -> list[str]:
    return [*group, *(a for name in group for a in _composed_sets(name, extra.get(name, [])))]


@dataclass
class RobotNodes:
    """One robot's nodes for a process that several robots share: extra[name] adds ``--set`` arguments."""

    robot_id: str
    nodes: list[str]
    extra: dict[str, list[str]] = field(default_factory=dict)


def shared_process(robots: list[RobotNodes], connect: list[str], *, params: Path | None = None,
                   zenoh_config: str | Path | None = None, mode: str = "auto") -> NodeProcess:
    """Several robots' nodes in one supervised process (robot_nodes.compose): the simulated team's layout, which the
    world's 100 Hz sensor messages reach once per process, not once per robot. Its robots share one loop thread
    (``--one-loop``: they wake together for each tick's sensors; on simulated time on the first robot's clock).
    Its members are named with their robot (robot2/hcm), so the supervisor names a failed node with it."""
    first, *more = robots
    argv = node_command("robot_nodes.compose", first.robot_id, connect, params,
                        ["--one-loop", *_composed_args(first.nodes, first.extra)], zenoh_config, mode)
    for robot in more:
        argv += [ROBOT_SEPARATOR, "--robot-id", robot.robot_id, *(["--params", str(params)] if params else []),
                 *_composed_args(robot.nodes, robot.extra)]
    members = [f"{robot.robot_id}/{node_label(n)}" for robot in robots for n in robot.nodes]
    return NodeProcess("+".join(robot.robot_id for robot in robots), argv, members=members)


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("nodes", nargs="+", help=f"nodes to start: {', '.join(NODES)}, or a team's own as "
                                                 "package.module (alone) or package.module:NodeClass")
    parser.add_argument("--robot-id", default="robot1")
    parser.add_argument("--params", type=Path, default=None)
    parser.add_argument("--compose", default="none", help=COMPOSE_HELP + " (default none)")
    parser.add_argument("--alone", action="append", default=[], metavar="NODE",
                        help="with --compose all: this node runs in a process of its own (repeatable), e.g. cm730 "
                             "on a real robot")
    add_bus_arguments(parser, connect_help="the Zenoh router to join (repeatable; default this machine's, "
                                           "tcp/127.0.0.1:7447); a router on another machine is joined through "
                                           "a router of this machine that this command starts",
                      config_help="a Zenoh JSON5 config: a robot's router file from `pitchside team-keys` runs "
                                  "that router here (nodes join it on loopback); a peer or client file goes to "
                                  "every node")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s [launch] %(message)s")
    try:
        groups = process_groups(args.nodes, args.compose, args.alone)
    except ValueError as exc:
        parser.error(str(exc))
    connect = args.connect or bus_from_arguments(args).connect
    router = None
    zenoh_config = args.zenoh_config
    try:
        if zenoh_config and is_router_config(zenoh_config):
            # a router's file (a robot's from `pitchside team-keys`): this machine's router runs it, and the nodes
            # join that router on loopback without the file (its key stays with the router)
            router = start_machine_router(args.listen, args.connect or None, zenoh_config)
            connect, zenoh_config = [router.local_endpoint], None
        elif not zenoh_config and remote(connect):
            router = start_machine_router(args.listen, connect)  # --listen: where that router listens
            connect = [router.local_endpoint]
    except ValueError as exc:
        raise SystemExit(f"launch: {exc}") from None
    launcher = Launcher(robot_processes(args.robot_id, groups, connect, params=args.params, zenoh_config=zenoh_config,
                                        mode=args.mode))
    try:
        run_until_signal(launcher)
    finally:
        if router is not None:
            router.close()


def run_until_signal(launcher: Launcher) -> None:
    def stop(signum: int, _frame: object) -> None:
        log.info("stopping all nodes on %s", signal.Signals(signum).name)
        launcher.stop()

    signal.signal(signal.SIGINT, stop)
    signal.signal(signal.SIGTERM, stop)
    launcher.run()


if __name__ == "__main__":
    main()
