"""The node's event loop: Zenoh threads hand work in, one thread runs it, timers keep their rate."""

from __future__ import annotations

import heapq
import itertools
import logging
import queue
import threading
import time
from collections.abc import Callable
from typing import Any

log = logging.getLogger(__name__)


class Timer:
    """A periodic callback; its measured rate goes into the node's diagnostics.

    A node with nothing to do pauses its timer and resumes it when work comes (a walk command, an animation
    goal): a paused timer costs nothing, the loop does not wake for it."""

    def __init__(self, loop: EventLoop, period: float, callback: Callable[[], None], name: str) -> None:
        self.period = period
        self.callback = callback
        self.name = name
        self.next_due = time.monotonic() + period
        self.cancelled = False
        self.active = True
        self.ticks = 0
        self.entry: int | None = None  # its current place in the loop's heap (older entries are stale)
        self._loop = loop

    def cancel(self) -> None:
        self.cancelled = True

    def set_rate(self, hz: float) -> None:
        self.period = 1.0 / hz

    def pause(self) -> None:
        """Stops ticking until resume (on the node's loop thread, like all node code)."""
        self.active = False

    def resume(self, at_once: bool = True) -> None:
        """Ticks again: at once, or a period from now (on the node's loop thread)."""
        if self.active or self.cancelled:
            return
        self.active = True
        self.next_due = time.monotonic() + (0.0 if at_once else self.period)
        self._loop.add_timer(self)


class EventLoop:
    """Runs callbacks one at a time on one thread, so node code needs no locks."""

    def __init__(self, on_error: Callable[[str, BaseException], None]) -> None:
        self._queue: queue.SimpleQueue[tuple[Callable[..., Any], tuple[Any, ...]] | None] = queue.SimpleQueue()
        self._timers: list[tuple[float, int, Timer]] = []
        self._counter = itertools.count()
        self._stop = threading.Event()
        self._on_error = on_error
        self.thread: threading.Thread | None = None

    def call_soon(self, fn: Callable[..., Any], *args: Any) -> None:
        """Thread-safe: schedule fn(*args) on the loop thread."""
        self._queue.put((fn, args))

    def add_timer(self, timer: Timer) -> None:
        """Only from the loop thread or before the loop runs."""
        timer.entry = next(self._counter)
        heapq.heappush(self._timers, (timer.next_due, timer.entry, timer))

    def stop(self) -> None:
        self._stop.set()
        self._queue.put(None)

    @property
    def stopped(self) -> bool:
        return self._stop.is_set()

    def run(self) -> None:
        self.thread = threading.current_thread()
        get = self._queue.get
        while not self._stop.is_set():
            timeout = self._run_due_timers()
            try:
                item = get(timeout=timeout)
            except queue.Empty:
                continue
            while item is not None:
                self._call(item[0], item[1])
                try:
                    item = self._queue.get_nowait()
                except queue.Empty:
                    break
                if self._stop.is_set():
                    return

    def _call(self, fn: Callable[..., Any], args: tuple[Any, ...]) -> None:
        try:
            fn(*args)
        except Exception as exc:  # a failing callback must not take the node down
            self._on_error(getattr(fn, "__qualname__", repr(fn)), exc)

    def _run_due_timers(self) -> float | None:
        """Fires due timers; returns seconds until the next one (None: no timer, wait for work or stop())."""
        now = time.monotonic()
        while self._timers and self._timers[0][0] <= now:
            _, entry, timer = heapq.heappop(self._timers)
            if entry != timer.entry:
                continue  # queued again since (resumed): this place is stale
            if timer.cancelled or not timer.active:
                timer.entry = None  # paused timers leave the heap; resume puts them back
                continue
            self._call(timer.callback, ())
            timer.ticks += 1
            timer.next_due += timer.period
            now = time.monotonic()
            if timer.next_due < now - timer.period:  # fell behind by more than a period: skip, don't burst
                timer.next_due = now + timer.period
            if timer.active and not timer.cancelled:  # the callback may have paused or cancelled it
                self.add_timer(timer)
        if not self._timers:
            return None
        return max(0.0, self._timers[0][0] - time.monotonic())
