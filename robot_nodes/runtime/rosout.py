"""A node's log records as ``rcl_interfaces/msg/Log`` on ``rosout``: what the node said reaches the dashboard and the
recordings (and Foxglove's Log panel), not only its terminal. A node cannot flood it: records beyond a token bucket
are dropped and counted."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

import schemas
from schemas.std import Log

RATE_PER_S = 20.0  # sustained records per second per node
BURST = 100  # records a node may send at once (a start-up, a fall) before the rate holds
MAX_TEXT = 4096  # characters of a record's text (with its traceback) on the wire


def log_level(levelno: int) -> int:
    """Python's level as the message's constant (10 DEBUG ... 50 FATAL); custom levels to the one below."""
    return max(Log.DEBUG, min(Log.FATAL, levelno // 10 * 10))


class RosoutHandler(logging.Handler):
    """Publishes each record of the loggers it is attached to; never raises, never recurses into itself."""

    def __init__(self, publish: Callable[[Log], None], name: str, rate_per_s: float = RATE_PER_S,
                 burst: int = BURST, level: int = logging.INFO) -> None:
        super().__init__(level)
        self._publish = publish
        self._name = name
        self._rate = rate_per_s
        self._burst = float(burst)
        self._tokens = float(burst)
        self._refilled = time.monotonic()
        self._lock_tokens = threading.Lock()
        self._inside = threading.local()  # a record logged while publishing one is not sent again
        self.sent = 0
        self.dropped = 0

    def emit(self, record: logging.LogRecord) -> None:
        if getattr(self._inside, "active", False):
            return
        if not self._take_token():
            self.dropped += 1
            return
        self._inside.active = True
        try:
            text = record.getMessage()
            if record.exc_info and record.exc_info[1] is not None:
                text += "\n" + (self.formatter or logging.Formatter()).formatException(record.exc_info)
            self._publish(Log(stamp=schemas.stamp(record.created), level=log_level(record.levelno), name=self._name,
                              msg=text[:MAX_TEXT], file=record.pathname, function=record.funcName,
                              line=record.lineno))
            self.sent += 1
        except Exception:  # a closed session at shutdown: the terminal still has the line
            self.dropped += 1
        finally:
            self._inside.active = False

    def _take_token(self) -> bool:
        with self._lock_tokens:
            now = time.monotonic()
            self._tokens = min(self._burst, self._tokens + (now - self._refilled) * self._rate)
            self._refilled = now
            if self._tokens < 1.0:
                return False
            self._tokens -= 1.0
            return True
