"""/api/recordings: list the recordings folder (size, duration), start/stop a recording, add a bookmark.

Recording sends nothing to robots, so it works in match mode too; it needs the token off loopback.
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Depends, HTTPException
from pydantic import BaseModel
from starlette.requests import HTTPConnection

from server.deps import require_token
from server.recorder import Recorder, RecorderError

router = APIRouter(prefix="/api/recordings", tags=["recordings"])


class StartRequest(BaseModel):
    name: str = ""


class BookmarkRequest(BaseModel):
    name: str
    data: dict[str, Any] | None = None


def get_recorder(conn: HTTPConnection) -> Recorder:
    recorder: Recorder | None = getattr(conn.app.state, "recorder", None)
    if recorder is None:
        raise HTTPException(503, "this server has no recorder")
    return recorder


@router.get("")
def list_recordings(recorder: Recorder = Depends(get_recorder)) -> dict[str, Any]:
    """The files (newest first, with size_bytes, duration_s, messages) and what is being recorded now."""
    return {"files": recorder.listing(), **recorder.status()}


@router.get("/status")
def recording_status(recorder: Recorder = Depends(get_recorder)) -> dict[str, Any]:
    return recorder.status()


@router.post("/start", dependencies=[Depends(require_token)])
async def start_recording(request: StartRequest | None = None, recorder: Recorder = Depends(get_recorder)
                          ) -> dict[str, Any]:
    try:
        status = await recorder.start_manual((request or StartRequest()).name)
    except RecorderError as exc:
        raise HTTPException(409, str(exc)) from exc
    return status.as_dict()


@router.post("/stop", dependencies=[Depends(require_token)])
async def stop_recording(recorder: Recorder = Depends(get_recorder)) -> dict[str, Any]:
    status = await recorder.stop_manual()
    if status is None:
        raise HTTPException(409, "no manual recording is running")
    return status.as_dict()


@router.post("/bookmark", dependencies=[Depends(require_token)])
async def add_bookmark(request: BookmarkRequest, recorder: Recorder = Depends(get_recorder)) -> dict[str, Any]:
    try:
        return {"recordings": recorder.bookmark(request.name, request.data)}
    except RecorderError as exc:
        raise HTTPException(409, str(exc)) from exc
