"""/api/replay: open a log, its contents (topics, counts, duration, bookmarks), and the timeline controls.

Replay feeds the server's own hub and sends nothing to robots: allowed in match mode (the token off loopback).
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Depends, HTTPException
from pydantic import BaseModel
from starlette.requests import HTTPConnection

from server.deps import require_token
from server.sources import SourceError
from server.sources.replay import ReplayRefused, ReplaySource

router = APIRouter(prefix="/api/replay", tags=["replay"])


class OpenRequest(BaseModel):
    path: str  # a file name in the recordings folder, or a path inside the folders given with --allow-folder


class SeekRequest(BaseModel):
    t_s: float  # seconds after the log's first message


class SpeedRequest(BaseModel):
    speed: float


class StepRequest(BaseModel):
    count: int = 1


def get_replay(conn: HTTPConnection) -> ReplaySource:
    replay: ReplaySource | None = getattr(conn.app.state, "replay", None)
    if replay is None:
        raise HTTPException(503, "this server has no replay source")
    return replay


def _conflict(exc: SourceError) -> HTTPException:
    return HTTPException(409, str(exc))


@router.get("")
def replay_status(replay: ReplaySource = Depends(get_replay)) -> dict[str, Any]:
    """Player state, position_s, duration_s, speed and the loading progress (0..1)."""
    return replay.status()


@router.get("/info")
def replay_info(replay: ReplaySource = Depends(get_replay)) -> dict[str, Any]:
    """The open file: topics (robot, topic, msgtype, count, known, decodable), duration, bookmarks."""
    try:
        return replay.info()
    except SourceError as exc:
        raise HTTPException(404, str(exc)) from exc


@router.post("/open", dependencies=[Depends(require_token)])
async def open_log(request: OpenRequest, replay: ReplaySource = Depends(get_replay)) -> dict[str, Any]:
    try:
        return await replay.open(request.path)
    except ReplayRefused as exc:
        raise HTTPException(403, str(exc)) from exc
    except SourceError as exc:
        raise HTTPException(404 if "no log file" in str(exc) else 422, str(exc)) from exc


@router.post("/close", dependencies=[Depends(require_token)])
async def close_log(replay: ReplaySource = Depends(get_replay)) -> dict[str, Any]:
    await replay.close()
    return replay.status()


@router.post("/play", dependencies=[Depends(require_token)])
async def play(replay: ReplaySource = Depends(get_replay)) -> dict[str, Any]:
    try:
        replay.play()
    except SourceError as exc:
        raise _conflict(exc) from exc
    return replay.status()


@router.post("/pause", dependencies=[Depends(require_token)])
async def pause(replay: ReplaySource = Depends(get_replay)) -> dict[str, Any]:
    try:
        replay.pause()
    except SourceError as exc:
        raise _conflict(exc) from exc
    return replay.status()


@router.post("/step", dependencies=[Depends(require_token)])
async def step(request: StepRequest | None = None, replay: ReplaySource = Depends(get_replay)) -> dict[str, Any]:
    try:
        return await replay.step((request or StepRequest()).count)
    except SourceError as exc:
        raise _conflict(exc) from exc


@router.post("/seek", dependencies=[Depends(require_token)])
async def seek(request: SeekRequest, replay: ReplaySource = Depends(get_replay)) -> dict[str, Any]:
    try:
        return await replay.seek(request.t_s)
    except SourceError as exc:
        raise _conflict(exc) from exc


@router.post("/speed", dependencies=[Depends(require_token)])
async def speed(request: SpeedRequest, replay: ReplaySource = Depends(get_replay)) -> dict[str, Any]:
    try:
        replay.set_speed(request.speed)
    except SourceError as exc:
        raise HTTPException(422, str(exc)) from exc
    return replay.status()
