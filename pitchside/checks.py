"""A doctor's check: its outcome, what it saw, and how to fix it; printed one line each (robot and laptop)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum


class Status(Enum):
    OK = "ok"
    FAIL = "FAIL"
    SKIP = "skip"


@dataclass(frozen=True)
class Check:
    """One check's outcome; ``fix`` says what to do when it failed."""

    name: str
    status: Status
    detail: str
    fix: str = ""


def report(checks: list[Check], say: Callable[[str], None] = print) -> int:
    """Prints the checks; returns how many failed."""
    width = max(len(c.name) for c in checks)
    for c in checks:
        say(f"{c.status.value:<4}  {c.name.ljust(width)}  {c.detail}")
        if c.status is Status.FAIL:
            say(f"{'':<4}  {'':<{width}}  fix: {c.fix}")
    return sum(c.status is Status.FAIL for c in checks)
