"""Starts a robot's nodes as supervised processes: a node that dies is restarted, and why is logged.

    python -m robot_nodes.launch --robot-id robot1 cm730 hcm animation

Each node runs as ``python -m <module> --robot-id ... --connect ...``; Ctrl-C (SIGINT) or SIGTERM stops all.
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

from wire.bus import add_bus_arguments, bus_from_arguments
from wire.command_line import CommandParser
from wire.machine_router import is_router_config, remote, start_machine_router

log = logging.getLogger("pitchside.launch")

# node name -> python module run with -m; the set a robot is made of
NODE_MODULES: dict[str, str] = {
    "cm730": "robot_nodes.cm730",
    "hcm": "robot_nodes.hcm",
    "animation": "robot_nodes.animation",
    "walking": "robot_nodes.walking",
    "pause": "robot_nodes.hcm.pause",
    "speaker": "robot_nodes.speaker",
    "game_controller": "robot_nodes.game_controller",
    "mitecom": "robot_nodes.mitecom",
    "telemetry": "robot_nodes.telemetry",
}


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

    def start(self) -> None:
        env = {**os.environ, **self.env}
        self.process = subprocess.Popen(self.argv, env=env)
        self.started_at = time.monotonic()
        log.info("started %s (pid %d)", self.name, self.process.pid)

    @property
    def pid(self) -> int | None:
        return self.process.pid if self.process is not None else None


def describe_exit(code: int) -> str:
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
        assert node.process is not None
        if node.given_up:
            return
        if node.restart_at is not None:
            if time.monotonic() >= node.restart_at:
                node.restart_at = None
                node.start()
            return
        code = node.process.poll()
        if code is None:
            return
        node.last_exit = describe_exit(code)
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


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("nodes", nargs="+", help=f"nodes to start: {', '.join(NODE_MODULES)} or a module path")
    parser.add_argument("--robot-id", default="robot1")
    parser.add_argument("--params", type=Path, default=None)
    add_bus_arguments(parser, connect_help="the Zenoh router to join (repeatable; default this machine's, "
                                           "tcp/127.0.0.1:7447); a router on another machine is joined through "
                                           "a router of this machine that this command starts",
                      config_help="a Zenoh JSON5 config: a robot's router file from `pitchside team-keys` runs "
                                  "that router here (nodes join it on loopback); a peer or client file goes to "
                                  "every node")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s [launch] %(message)s")
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
    launcher = Launcher([
        NodeProcess(name, node_command(NODE_MODULES.get(name, name), args.robot_id, connect, args.params,
                                       zenoh_config=zenoh_config, mode=args.mode))
        for name in args.nodes
    ])
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
