"""The server's one Zenoh session: opened on first use, and never in match mode."""

from __future__ import annotations

import threading

import zenoh

from wire.bus import BusConfig, open_session


class MatchModeError(RuntimeError):
    """Refused because in match mode the server sends nothing to any robot."""


MATCH_MODE_REASON = (
    "match mode: the server sends no packet to any robot (RoboCup rules allow only one-way UDP from robots "
    "to the team PC), so control is off and no Zenoh session is opened"
)


class ZenohLink:
    """Shared by the live source and the control API; ``session()`` refuses in match mode."""

    def __init__(self, bus: BusConfig, match_mode: bool) -> None:
        self.bus = bus
        self.match_mode = match_mode
        self._session: zenoh.Session | None = None
        self._lock = threading.Lock()

    @property
    def is_open(self) -> bool:
        return self._session is not None

    def session(self) -> zenoh.Session:
        """Blocking (opening takes a few ms to 0.5 s): call it from a worker thread, not the event loop."""
        if self.match_mode:
            raise MatchModeError(MATCH_MODE_REASON)
        with self._lock:
            if self._session is None:
                self._session = open_session(self.bus)
            return self._session

    def close(self) -> None:
        with self._lock:
            session, self._session = self._session, None
        if session is not None:
            session.close()
