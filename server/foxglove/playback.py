"""Foxglove's PlaybackControl on the server's replay (server.sources.replay): the same player the dashboard's replay
panel drives, so both stay in step.

While a log is open the endpoint serves its streams with the log's own timestamps, announces the log's time range,
and moves Foxglove's clock with the replay (the Time capability). Play, pause, seek and speed from Foxglove's
playback bar act on the replay as the panel's buttons do (speed within the panel's 0.1x-10x); what the panel does
(or the replay reaching the end) goes to Foxglove as a playback state within ``SYNC_S``. Controlling the replay needs
the token, as the replay panel's controls do; clients without it watch.
"""

from __future__ import annotations

import asyncio
import logging
from typing import Any

from foxglove.websocket import PlaybackCommand, PlaybackState, PlaybackStatus

from server.sources.replay import MAX_SPEED, MIN_SPEED, ReplaySource

log = logging.getLogger(__name__)
SYNC_S = 0.1  # how often the replay's state is compared with what Foxglove was told
REQUEST_TIMEOUT_S = 10.0
_STATUS = {"playing": PlaybackStatus.Playing, "paused": PlaybackStatus.Paused, "ended": PlaybackStatus.Ended,
           "loading": PlaybackStatus.Buffering}


class ReplayPlayback:
    """Answers Foxglove's playback requests (SDK threads) on the replay (event loop), and notices the replay's own
    changes (``changes``, on the loop)."""

    def __init__(self, replay: ReplaySource, loop: asyncio.AbstractEventLoop) -> None:
        self.replay = replay
        self.loop = loop
        self._told: tuple[str, float, int] | None = None  # state, speed and seek count Foxglove was told last

    def time_range(self) -> tuple[int, int] | None:
        file = self.replay.file
        return (file.start_ns, file.end_ns) if file is not None else None

    def state(self, did_seek: bool = False, request_id: str | None = None) -> PlaybackState:
        status = self.replay.status()
        position = int(status.get("position_ns") or 0)
        return PlaybackState(status=_STATUS.get(status["state"], PlaybackStatus.Paused), current_time=position,
                             playback_speed=float(status["speed"]), did_seek=did_seek, request_id=request_id)

    # -- Foxglove asks ------------------------------------------------------------------------------------------
    def request(self, request: Any) -> PlaybackState:
        """A PlaybackControlRequest: seek first (Foxglove loops by seeking to the start, then playing), then speed,
        then play or pause. Blocks the asking client's thread until the replay did it."""
        future = asyncio.run_coroutine_threadsafe(self._apply(request), self.loop)
        try:
            return future.result(REQUEST_TIMEOUT_S)
        except Exception as exc:  # no log open any more, a log that broke: say where the replay is
            log.warning("foxglove: playback request not done: %s", exc)
            return self.state(request_id=request.request_id)

    async def _apply(self, request: Any) -> PlaybackState:
        replay = self.replay
        range_ = self.time_range()
        did_seek = request.seek_time is not None and range_ is not None
        if did_seek and range_ is not None:
            await replay.seek((max(range_[0], min(int(request.seek_time), range_[1])) - range_[0]) / 1e9)
        speed = float(request.playback_speed)
        if speed == speed and speed > 0:  # not NaN: Foxglove's speeds are 0.01x..; the panel's are 0.1x-10x
            replay.set_speed(min(MAX_SPEED, max(MIN_SPEED, speed)))
        if request.playback_command == PlaybackCommand.Play:
            replay.play()
        else:
            replay.pause()
        state = self.state(did_seek=did_seek, request_id=request.request_id)
        self._remember(state)
        return state

    # -- the replay changed by itself, or from the dashboard ----------------------------------------------------
    def changes(self) -> PlaybackState | None:
        """The state to broadcast when it is not what Foxglove was told last (on the loop, every ``SYNC_S``)."""
        state = self.state()
        told = self._told
        now = (self.replay.state, float(state.playback_speed), self.replay.seeks)
        if told == now:
            return None
        self._told = now
        did_seek = told is not None and told[2] != now[2]
        return PlaybackState(status=state.status, current_time=state.current_time,
                             playback_speed=state.playback_speed, did_seek=did_seek, request_id=None)

    def forget_told(self) -> None:
        """New servers: their clients were told nothing yet."""
        self._told = None

    def _remember(self, state: PlaybackState) -> None:
        self._told = (self.replay.state, float(state.playback_speed), self.replay.seeks)
