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
    """A periodic callback; its measured rate goes into the node's diagnostics."""

    def __init__(self, loop: EventLoop, period: float, callback: Callable[[], None], name: str) -> None:
        self.period = period
        self.callback = callback
        self.name = name
        self.next_due = time.monotonic() + period
        self.cancelled = False
        self.ticks = 0
        self._loop = loop

    def cancel(self) -> None:
        self.cancelled = True

    def set_rate(self, hz: float) -> None:
        self.period = 1.0 / hz


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
        heapq.heappush(self._timers, (timer.next_due, next(self._counter), timer))

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

    def _run_due_timers(self) -> float:
        """Fires due timers; returns seconds until the next one (capped so stop() is noticed)."""
        now = time.monotonic()
        while self._timers and self._timers[0][0] <= now:
            _, _, timer = heapq.heappop(self._timers)
            if timer.cancelled:
                continue
            self._call(timer.callback, ())
            timer.ticks += 1
            timer.next_due += timer.period
            now = time.monotonic()
            if timer.next_due < now - timer.period:  # fell behind by more than a period: skip, don't burst
                timer.next_due = now + timer.period
            heapq.heappush(self._timers, (timer.next_due, next(self._counter), timer))
        if not self._timers:
            return 0.5
        return max(0.0, min(0.5, self._timers[0][0] - time.monotonic()))
