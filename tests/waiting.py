"""Waiting on conditions with a timeout, instead of sleeping and hoping."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")


def wait_for(condition: Callable[[], T], timeout: float = 5.0, interval: float = 0.01,
             what: str | Callable[[], str] = "") -> T:
    """Returns the first truthy value of condition(); AssertionError after timeout. ``what`` says what was waited
    for; a callable is asked only then (for a message that costs something to make, e.g. a screenshot's verdict)."""
    deadline = time.monotonic() + timeout
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            said = what() if callable(what) else what
            raise AssertionError(f"timed out after {timeout} s waiting for {said or condition}")
        time.sleep(interval)
