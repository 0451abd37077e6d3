"""How the recorder and the replay source join a dashboard app (routers find them in the server state)."""

from __future__ import annotations

import logging

from server.recorder import Recorder
from server.recorder_remote import RemoteRecorder
from server.security import AllowedFolders
from server.sources import SourceError
from server.sources.replay import ReplaySource
from server.state import ServerState

log = logging.getLogger(__name__)


class RecordingAndReplay:
    """Started and stopped by the app's lifespan; the routers reach the two parts as ``state.recorder`` and
    ``state.replay``."""

    def __init__(self, state: ServerState) -> None:
        config = state.config
        folder = config.recordings_dir
        self.state = state
        self.recorder: Recorder | RemoteRecorder
        if config.recorder_url:  # the recorder is a process of its own: this server only controls it
            self.recorder = RemoteRecorder(config.recorder_url, config.recorder_token, folder,
                                           config.auto_record_matches)
        else:
            self.recorder = Recorder(state.hub, folder, auto_match=config.auto_record_matches,
                                     description_for=config.description_for)
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


def attach_recording(state: ServerState) -> RecordingAndReplay:
    recording = RecordingAndReplay(state)
    state.recorder = recording.recorder
    state.replay = recording.replay
    return recording
