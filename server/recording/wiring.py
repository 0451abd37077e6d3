"""How the recorder and the replay source join a dashboard app (routers find them in ``app.state``)."""

from __future__ import annotations

import logging
from typing import Any

from server.recorder import Recorder
from server.security import AllowedFolders
from server.sources import SourceError
from server.sources.replay import ReplaySource
from server.state import ServerState

log = logging.getLogger(__name__)


class RecordingAndReplay:
    """Kept in ``state.views["recording"]`` so the app's lifespan stops it with the other views."""

    def __init__(self, state: ServerState) -> None:
        config = state.config
        folder = config.recordings_dir
        self.state = state
        self.recorder = Recorder(state.hub, folder, auto_match=config.auto_record_matches)
        self.replay = ReplaySource(state.hub, folder, AllowedFolders(config.replay_folders, "logs"))

    async def start(self) -> None:
        await self.recorder.start()
        replay_file = self.state.config.replay_file
        if replay_file:
            try:
                await self.replay.open(replay_file)
            except SourceError as exc:
                log.error("replay file not opened: %s", exc)

    async def stop(self) -> None:
        await self.replay.shutdown()
        await self.recorder.close()


def attach_recording(app: Any, state: ServerState) -> RecordingAndReplay:
    lab = RecordingAndReplay(state)
    app.state.recorder = lab.recorder
    app.state.replay = lab.replay
    state.views["recording"] = lab
    return lab
