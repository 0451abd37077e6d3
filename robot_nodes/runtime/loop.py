"""The node's event loop: Zenoh threads hand work in, one thread runs it, timers keep their rate (in the time of
the node's clock: the wall clock, or the simulation's, robot_nodes/runtime/clock.py)."""

from __future__ import annotations

import heapq
import itertools
import logging
import math
import queue
import threading
import time
from collections.abc import Callable
from typing import Any

from robot_nodes.runtime.clock import WALL_CLOCK, Clock

log = logging.getLogger(__name__)


def timer_period_s(rate_hz: float | None, period_s: float | None) -> float:
    """A timer's period from its rate or its period, exactly one given, finite and above 0 (else ValueError)."""
    if (rate_hz is None) == (period_s is None):
        raise ValueError(f"a timer takes rate_hz or period_s, exactly one (got rate_hz={rate_hz}, period_s={period_s})")
    period = period_s if period_s is not None else 1.0 / rate_hz if rate_hz else math.inf
    if not (0.0 < period < math.inf):
        raise ValueError(f"a timer's period must be finite and above 0 s (rate_hz={rate_hz}, period_s={period_s})")
    return period


class Timer:
    """A periodic callback; its measured rate goes into the node's diagnostics.

    A node with nothing to do pauses its timer and resumes it when work comes (a walk command, an animation
    goal): a paused timer costs nothing, the loop does not wake for it."""

    def __init__(self, loop: EventLoop, period_s: float, callback: Callable[[], None], name: str) -> None:
        self.period_s = period_s
        self.callback = callback
        self.name = name
        self.next_due = loop.clock.now() + period_s
        self.cancelled = False
        self.active = True
        self.ticks = 0
        self.entry: int | None = None  # its current place in the loop's heap (older entries are stale)
        self._loop = loop

    def cancel(self) -> None:
        self.cancelled = True

    def set_rate(self, rate_hz: float) -> None:
        self.period_s = timer_period_s(rate_hz, None)

    def set_period(self, period_s: float) -> None:
        self.period_s = timer_period_s(None, period_s)

    def pause(self) -> None:
        """Stops ticking until resume (on the node's loop thread, like all node code)."""
        self.active = False

    def resume(self, at_once: bool = True) -> None:
        """Ticks again: at once, or a period from now (on the node's loop thread)."""
        if self.active or self.cancelled:
            return
        self.active = True
        self.next_due = self._loop.clock.now() + (0.0 if at_once else self.period_s)
        self._loop.add_timer(self)


class EventLoop:
    """Runs callbacks one at a time on one thread, so node code needs no locks.

    on_error(callback, exception): a callback that raised (the loop goes on). timed: keep the longest callback's
    duration (``longest_call_s``), for a loop that several nodes share (robot_nodes/runtime/one_loop.py)."""

    def __init__(self, on_error: Callable[[Callable[..., Any], BaseException], None], clock: Clock = WALL_CLOCK,
                 timed: bool = False) -> None:
        self.clock = clock
        self.next_due = math.inf  # of its first timer, for a simulated clock to wake the loop (clock.py)
        self._queue: queue.SimpleQueue[tuple[Callable[..., Any], tuple[Any, ...]] | None] = queue.SimpleQueue()
        self._timers: list[tuple[float, int, Timer]] = []
        self._counter = itertools.count()
        self._stop = threading.Event()
        self._on_error = on_error
        self._timed = timed
        self.longest_call_s = 0.0
        self.longest_call = ""
        self.thread: threading.Thread | None = None
        # a lockstep clock asks whether anything waits (clock.py): the items queued and not yet done
        self._counted = clock.lockstep
        self._pending = 0
        self._pending_lock = threading.Lock()

    def call_soon(self, fn: Callable[..., Any], *args: Any) -> None:
        """Thread-safe: schedule fn(*args) on the loop thread."""
        if self._counted:
            with self._pending_lock:
                self._pending += 1
        self._queue.put((fn, args))

    def add_timer(self, timer: Timer) -> None:
        """Only from the loop thread or before the loop runs."""
        timer.entry = next(self._counter)
        heapq.heappush(self._timers, (timer.next_due, timer.entry, timer))
        self.next_due = min(self.next_due, timer.next_due)

    def wake(self) -> None:
        """Thread-safe: look at the timers again (the simulated clock passed the next one)."""
        self.call_soon(_nothing)

    def quiet(self, until: float) -> bool:
        """No message waiting or being handled, no timer due up to ``until`` (a lockstep clock asks)."""
        return self._pending == 0 and self.next_due > until

    def stop(self) -> None:
        self._stop.set()
        self._queue.put(None)

    @property
    def stopped(self) -> bool:
        return self._stop.is_set()

    def run(self) -> None:
        self.thread = threading.current_thread()
        get = self._queue.get
        self.clock.watch(self)
        try:
            while not self._stop.is_set():
                timeout = self._run_due_timers()
                if self._counted:
                    self.clock.settled()
                try:
                    item = get(timeout=timeout)
                except queue.Empty:
                    continue
                while item is not None:
                    self._call(item[0], item[1])
                    if self._counted:
                        with self._pending_lock:
                            self._pending -= 1
                    try:
                        item = self._queue.get_nowait()
                    except queue.Empty:
                        break
                    if self._stop.is_set():
                        return
        finally:
            self.clock.unwatch(self)

    def _call(self, fn: Callable[..., Any], args: tuple[Any, ...]) -> None:
        started = time.perf_counter() if self._timed else 0.0
        try:
            fn(*args)
        except Exception as exc:  # a failing callback must not take the node down
            self._on_error(fn, exc)
        if self._timed and time.perf_counter() - started > self.longest_call_s:
            self.longest_call_s = time.perf_counter() - started
            self.longest_call = getattr(fn, "__qualname__", repr(fn))

    def _run_due_timers(self) -> float | None:
        """Fires due timers; returns wall seconds until the next one (None: no timer, or a simulated clock that
        wakes the loop when it gets there; wait for work or stop())."""
        clock = self.clock
        slack = clock.slack
        now = clock.now() + slack
        while self._timers and self._timers[0][0] <= now:
            _, entry, timer = heapq.heappop(self._timers)
            if entry != timer.entry:
                continue  # queued again since (resumed): this place is stale
            if timer.cancelled or not timer.active:
                timer.entry = None  # paused timers leave the heap; resume puts them back
                continue
            self._call(timer.callback, ())
            timer.ticks += 1
            timer.next_due += timer.period_s
            now = clock.now() + slack
            if timer.next_due < now - timer.period_s:  # fell behind by more than a period: skip, don't burst
                timer.next_due = clock.now() + timer.period_s  # on the clock's grid (slack added would straddle it)
            if timer.active and not timer.cancelled:  # the callback may have paused or cancelled it
                self.add_timer(timer)
        if not self._timers:
            self.next_due = math.inf
            return None
        self.next_due = self._timers[0][0]  # before the clock is read again: see SimClock
        return clock.wall_timeout(self.next_due)


def _nothing() -> None:
    """What wake() puts in the queue: the loop looks at its timers after it."""

