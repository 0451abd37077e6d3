"""/api/recordings: list the recordings folder (size, duration), start/stop a recording, add a bookmark.

Recording sends nothing to robots, so it works in match mode too; it needs the token off loopback.
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Depends, HTTPException
from fastapi.responses import FileResponse
from pydantic import BaseModel

from schemas.logs import LogError
from server.deps import get_state, require_token
from server.recorder import Recorder
from server.state import ServerState

router = APIRouter(prefix="/api/recordings", tags=["recordings"])


class StartRequest(BaseModel):
    name: str = ""


class BookmarkRequest(BaseModel):
    name: str
    data: dict[str, Any] | None = None


class Recording(BaseModel):
    """A running (or finished) recording."""

    name: str
    path: str
    reason: str  # "manual", "match", "cli"
    started: float  # wall clock
    stopped: float | None
    running: bool
    duration_s: float
    messages: int  # handed to the writer
    flushed_messages: int  # known to be on disk
    skipped: int  # messages that cannot be stored
    dropped: int  # lost because the writer fell behind
    bookmarks: int
    files: list[str]
    error: str
    resumed: bool  # continues a recording that a crash of the server cut off


class RecorderStatus(BaseModel):
    folder: str
    auto_match: bool
    manual: Recording | None
    match: Recording | None
    recent: list[Recording]


class RecordingFile(BaseModel):
    """A file of the folder; one being written has its size only (its index comes at the end)."""

    name: str
    size_bytes: int
    modified: float
    recording: bool
    duration_s: float | None = None
    messages: int | None = None
    robots: list[str] | None = None
    indexed: bool | None = None
    bookmarks: int | None = None
    error: str | None = None  # a file that cannot be read: why


class RecordingsListing(RecorderStatus):
    files: list[RecordingFile]


class Bookmarked(BaseModel):
    recordings: list[str]  # the recordings marked


def get_recorder(state: ServerState = Depends(get_state)) -> Recorder:
    if state.recorder is None:
        raise HTTPException(503, "this server has no recorder")
    return state.recorder


@router.get("", response_model=RecordingsListing, response_model_exclude_unset=True)
def list_recordings(recorder: Recorder = Depends(get_recorder)) -> dict[str, Any]:
    """The files (newest first, with size_bytes, duration_s, messages) and what is being recorded now."""
    return {"files": recorder.listing(), **recorder.status()}


@router.get("/files/{name}", response_class=FileResponse)
def download_recording(name: str, recorder: Recorder = Depends(get_recorder)) -> FileResponse:
    """One MCAP file of the recordings folder as a download (by its bare name: nothing outside the folder)."""
    try:
        path = recorder.files.resolve(name)
    except LogError as exc:
        raise HTTPException(404, str(exc)) from None
    return FileResponse(path, media_type="application/octet-stream", filename=path.name)


@router.get("/status", response_model=RecorderStatus)
def recording_status(recorder: Recorder = Depends(get_recorder)) -> dict[str, Any]:
    return recorder.status()


@router.post("/start", dependencies=[Depends(require_token)], response_model=Recording)
async def start_recording(request: StartRequest | None = None, recorder: Recorder = Depends(get_recorder)
                          ) -> dict[str, Any]:
    """409 if a manual recording runs already (server.http_errors)."""
    status = await recorder.start_manual((request or StartRequest()).name)
    return status.as_dict()


@router.post("/stop", dependencies=[Depends(require_token)], response_model=Recording)
async def stop_recording(recorder: Recorder = Depends(get_recorder)) -> dict[str, Any]:
    status = await recorder.stop_manual()
    if status is None:
        raise HTTPException(409, "no manual recording is running")
    return status.as_dict()


@router.post("/bookmark", dependencies=[Depends(require_token)])
async def add_bookmark(request: BookmarkRequest, recorder: Recorder = Depends(get_recorder)) -> Bookmarked:
    """409 when nothing is being recorded (server.http_errors)."""
    return Bookmarked(recordings=recorder.bookmark(request.name, request.data))
