"""/api/replay: open a log, its contents (topics, counts, duration, bookmarks), and the timeline controls.

Replay feeds the server's own hub and sends nothing to robots: allowed in match mode (the token off loopback).
A log outside the allowed folders is 403, a missing one 404, one that cannot be read 422, a timeline control with
no log open 409 (server.http_errors).
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Depends, HTTPException
from pydantic import BaseModel

from server.deps import get_state, require_token
from server.sources.replay import NoLogOpen, ReplaySource
from server.state import ServerState

router = APIRouter(prefix="/api/replay", tags=["replay"])


class OpenRequest(BaseModel):
    path: str  # a file name in the recordings folder, or a path inside the folders given with --allow-folder


class SeekRequest(BaseModel):
    t_s: float  # seconds after the log's first message


class SpeedRequest(BaseModel):
    speed: float


class StepRequest(BaseModel):
    count: int = 1


class ReplayStatus(BaseModel):
    name: str  # the source's name, "replay"
    running: bool
    error: str
    state: str  # "closed", "loading", "paused", "playing"
    progress: float  # loading, 0..1
    speed: float
    delivered: int
    skipped: int
    path: str | None  # the open log
    position_s: float | None = None  # with a log open: seconds after its first message
    duration_s: float | None = None
    position_ns: int | None = None


class LogTopic(BaseModel):
    robot: str
    topic: str
    msgtype: str
    count: int
    known: bool  # in the topic table
    decodable: bool
    problem: str  # why not decodable


class LogBookmark(BaseModel):
    name: str
    t_s: float
    log_time_ns: int
    data: Any
    kind: str  # "log": in the file (GameController events, bookmarks made while recording); "note": added since


class NoteRequest(BaseModel):
    name: str
    t_s: float | None = None  # seconds after the log's start; None: the replay's position


class LogInfo(BaseModel):
    path: str
    files: list[str]  # the series of files the log is made of
    start_ns: int
    end_ns: int
    duration_s: float
    messages: int
    topics: list[LogTopic]
    robots: list[str]
    bookmarks: list[LogBookmark]
    notes_file: str  # where notes added to this log are kept (beside it; the log itself is never changed)
    warnings: list[str]


def get_replay(state: ServerState = Depends(get_state)) -> ReplaySource:
    if state.replay is None:
        raise HTTPException(503, "this server has no replay source")
    return state.replay


@router.get("", response_model=ReplayStatus, response_model_exclude_unset=True)
def replay_status(replay: ReplaySource = Depends(get_replay)) -> dict[str, Any]:
    """Player state, position_s, duration_s, speed and the loading progress (0..1)."""
    return replay.status()


@router.get("/info", response_model=LogInfo)
def replay_info(replay: ReplaySource = Depends(get_replay)) -> dict[str, Any]:
    """The open file: topics (robot, topic, msgtype, count, known, decodable), duration, bookmarks."""
    try:
        return replay.info()
    except NoLogOpen as exc:  # the contents of no log: not there (a control with no log open is a conflict)
        raise HTTPException(404, str(exc)) from exc


@router.post("/open", dependencies=[Depends(require_token)], response_model=LogInfo)
async def open_log(request: OpenRequest, replay: ReplaySource = Depends(get_replay)) -> dict[str, Any]:
    return await replay.open(request.path)


@router.post("/close", dependencies=[Depends(require_token)], response_model=ReplayStatus,
             response_model_exclude_unset=True)
async def close_log(replay: ReplaySource = Depends(get_replay)) -> dict[str, Any]:
    await replay.close()
    return replay.status()


@router.post("/play", dependencies=[Depends(require_token)], response_model=ReplayStatus,
             response_model_exclude_unset=True)
async def play(replay: ReplaySource = Depends(get_replay)) -> dict[str, Any]:
    replay.play()
    return replay.status()


@router.post("/pause", dependencies=[Depends(require_token)], response_model=ReplayStatus,
             response_model_exclude_unset=True)
async def pause(replay: ReplaySource = Depends(get_replay)) -> dict[str, Any]:
    replay.pause()
    return replay.status()


@router.post("/step", dependencies=[Depends(require_token)], response_model=ReplayStatus,
             response_model_exclude_unset=True)
async def step(request: StepRequest | None = None, replay: ReplaySource = Depends(get_replay)) -> dict[str, Any]:
    return await replay.step((request or StepRequest()).count)


@router.post("/seek", dependencies=[Depends(require_token)], response_model=ReplayStatus,
             response_model_exclude_unset=True)
async def seek(request: SeekRequest, replay: ReplaySource = Depends(get_replay)) -> dict[str, Any]:
    return await replay.seek(request.t_s)


@router.post("/speed", dependencies=[Depends(require_token)], response_model=ReplayStatus,
             response_model_exclude_unset=True)
async def speed(request: SpeedRequest, replay: ReplaySource = Depends(get_replay)) -> dict[str, Any]:
    replay.set_speed(request.speed)
    return replay.status()


@router.post("/bookmark", dependencies=[Depends(require_token)], response_model=LogBookmark)
async def add_note(request: NoteRequest, replay: ReplaySource = Depends(get_replay)) -> dict[str, Any]:
    """A named bookmark (a note) on the open log at the replay's position, or at t_s: kept in a sidecar file beside
    the log (``<log>.notes.json``), listed with the log's bookmarks whenever it is opened again. 409 with no log
    open, 422 for a bad name or a sidecar that cannot be written."""
    return await replay.add_note(request.name, request.t_s)
