"""Several nodes of one process on one loop thread: what one thread per node costs, saved where it counts.

Each node keeps its name, parameters, timers, diagnostics and subscriptions; only the thread is shared, so a
callback of one node waits while another's runs. Use it for nodes whose every callback is short and known, such as
the simulated world's cm730 nodes (one per robot, each tick well under a millisecond: with 8 robots one loop took a
tenth of a core less than 8 loops in bench/team.py), never for a node that may block (a serial port, a file, a
speaker). The bound: a node waits at most for the other nodes' callbacks due at the same time; the loop keeps its
longest callback of each second (``longest_call_s``) and each node's diagnostics say it (``loop_longest_call_ms``).
"""

from __future__ import annotations

import logging
import threading
import traceback
from collections.abc import Callable
from typing import Any

import zenoh

from robot_nodes.runtime.clock import WALL_CLOCK, Clock, RobotSimClock, sim_time_wanted
from robot_nodes.runtime.local_bus import LocalBus
from robot_nodes.runtime.loop import EventLoop, Timer
from robot_nodes.runtime.node import Node

log = logging.getLogger(__name__)
REPORT_PERIOD_S = 1.0


class NodesOnOneLoop:
    """Make each node with ``loop=group.loop`` and ``group.add`` it; ``start`` runs them all, ``shutdown`` ends
    them all (a node's own ``shutdown`` takes it off the loop and leaves the others running)."""

    def __init__(self, name: str, clock: Clock = WALL_CLOCK) -> None:
        self.name = name
        self.loop = EventLoop(self._on_error, clock, timed=True)
        self.nodes: list[Node] = []
        self.failed: Node | None = None  # the node whose callback ended the loop (an exception no node may raise)
        self._thread: threading.Thread | None = None
        self._on_close: list[Callable[[], None]] = []

    @classmethod
    def of_robot(cls, session: zenoh.Session, robot_id: str) -> NodesOnOneLoop:
        """A loop for nodes of one robot, on the clock they follow: the robot's simulated clock when the process
        simulates (PITCHSIDE_SIM_TIME, the clock each node joins too), else the wall clock."""
        bus = LocalBus.join(session)
        robot_clock = RobotSimClock.join(bus, robot_id) if sim_time_wanted() else None
        group = cls(robot_id, robot_clock or WALL_CLOCK)
        if robot_clock is not None:
            group._on_close.append(robot_clock.leave)
        group._on_close.append(bus.leave)
        return group

    @classmethod
    def of_process(cls, session: zenoh.Session, name: str, clock_of: str | None = None) -> NodesOnOneLoop:
        """A loop for the nodes of several robots: on the wall clock, or (``clock_of``) on that robot's simulated
        clock, which every node of the group then follows (robots of one world share its time; give each node
        ``clock=group.loop.clock``)."""
        bus = LocalBus.join(session)
        robot_clock = RobotSimClock.join(bus, clock_of) if clock_of is not None else None
        group = cls(name, robot_clock or WALL_CLOCK)
        if robot_clock is not None:
            group._on_close.append(robot_clock.leave)
        group._on_close.append(bus.leave)
        return group

    def add(self, node: Node) -> Node:
        if node.loop is not self.loop:
            raise ValueError(f"{node.name} of {node.robot_id} was not made with this group's loop")
        self.nodes.append(node)
        return node

    def start(self) -> NodesOnOneLoop:
        for node in self.nodes:
            node.schedule_first_reports()
        self.loop.add_timer(Timer(self.loop, REPORT_PERIOD_S, self._report, "one_loop_report"))
        self._thread = threading.Thread(target=self._run, name=f"loop-{self.name}", daemon=True)
        self._thread.start()
        return self

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def shutdown(self) -> None:
        for node in self.nodes:
            node.shutdown()
        self.loop.stop()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(5.0)
        for leave in self._on_close:
            leave()
        self._on_close.clear()

    def _run(self) -> None:
        try:
            self.loop.run()
        except BaseException as exc:  # not an Exception (those a node's own): the loop ends; say whose it was
            self.failed = _raised_by(exc, self.nodes)
            raise

    def _report(self) -> None:
        """Each node's diagnostics say whom it shares its loop with and the loop's longest callback of the last
        period (the longest another node's callback may have waited; start-up's first calls are the slowest)."""
        longest = f"{self.loop.longest_call_s * 1e3:.2f} ({self.loop.longest_call})"
        self.loop.longest_call_s, self.loop.longest_call = 0.0, ""
        for node in self.nodes:
            node.set_diagnostic("loop_shared_by", len(self.nodes))
            node.set_diagnostic("loop_longest_call_ms", longest)

    def _on_error(self, callback: Callable[..., Any], exc: BaseException) -> None:
        """Counted on the node whose callback raised: a timer's or a message's (the callback's object is the node,
        or holds it), else logged for the group."""
        owner = _owner(callback)
        if owner is not None:
            owner._on_callback_error(callback, exc)
            return
        log.warning("%s: %s: %s: %s", self.name, getattr(callback, "__qualname__", repr(callback)),
                    type(exc).__name__, exc)
        log.debug("".join(traceback.format_exception(exc)))


def _raised_by(exc: BaseException, nodes: list[Node]) -> Node | None:
    """The innermost node of ``nodes`` whose method the exception passed through."""
    found = None
    tb = exc.__traceback__
    while tb is not None:
        candidate = tb.tb_frame.f_locals.get("self")
        if any(candidate is node for node in nodes):
            found = candidate
        tb = tb.tb_next
    return found


def _owner(callback: Callable[..., Any]) -> Node | None:
    target = getattr(callback, "__self__", None)
    for candidate in (target, getattr(target, "node", None), getattr(target, "_node", None)):
        if isinstance(candidate, Node):
            return candidate
    return None
