"""/api/recordings: list the recordings folder (size, duration), start/stop a recording, add a bookmark.

Recording sends nothing to robots, so it works in match mode too; it needs the token off loopback.
"""

from __future__ import annotations

import io
import zipfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from fastapi import APIRouter, Depends, HTTPException
from fastapi.responses import FileResponse, StreamingResponse
from pydantic import BaseModel, Field

from schemas.logs import LogError, log_series
from server.deps import get_state, require_token
from server.recorder import Recorder
from server.recorder_remote import RemoteRecorder
from server.state import ServerState

AnyRecorder = Recorder | RemoteRecorder  # in this server, or the recorder process beside it
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


class RecorderOutage(BaseModel):
    """A time the recorder process did not answer (wall clock): its recordings have a gap about this long."""

    from_: float = Field(alias="from")
    to: float
    down_s: float


class RecorderProcess(BaseModel):
    """The recorder process beside the dashboard (None: the recorder runs inside this server)."""

    separate: bool
    up: bool  # answering now
    down_since: float | None  # wall clock; None while up
    pid: int | None
    restarts: int  # new recorder processes since this dashboard started
    outages: list[RecorderOutage]
    error: str  # the running recording's error (disk full, folder read-only), "" when none


class RecorderStatus(BaseModel):
    folder: str
    auto_match: bool
    manual: Recording | None
    match: Recording | None
    recent: list[Recording]
    process: RecorderProcess | None = None


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
    series: list[str] | None = None  # the first file of a size-rotated recording (a half): all its files, in order
    pulled: list[str] | None = None  # a match log's half: the robots whose own logs were pulled and merged


class RecordingsListing(RecorderStatus):
    files: list[RecordingFile]


class Bookmarked(BaseModel):
    recordings: list[str]  # the recordings marked


def get_recorder(state: ServerState = Depends(get_state)) -> AnyRecorder:
    if state.recorder is None:
        raise HTTPException(503, "this server has no recorder")
    return state.recorder


@router.get("", response_model=RecordingsListing, response_model_exclude_unset=True)
def list_recordings(recorder: AnyRecorder = Depends(get_recorder)) -> dict[str, Any]:
    """The files (newest first, with size_bytes, duration_s, messages) and what is being recorded now; the first
    file of a rotated recording names its series (downloaded at once from /series/<name>)."""
    files = recorder.listing()
    for entry in files:
        parts = log_series(recorder.files.folder / entry["name"])
        if len(parts) > 1:
            entry["series"] = [p.name for p in parts]
    return {"files": files, **recorder.status()}


@router.get("/files/{name}", response_class=FileResponse)
def download_recording(name: str, recorder: AnyRecorder = Depends(get_recorder)) -> FileResponse:
    """One MCAP file of the recordings folder as a download (by its bare name: nothing outside the folder)."""
    try:
        path = recorder.files.resolve(name)
    except LogError as exc:
        raise HTTPException(404, str(exc)) from None
    return FileResponse(path, media_type="application/octet-stream", filename=path.name)


@router.get("/series/{name}", response_class=StreamingResponse)
def download_series(name: str, recorder: AnyRecorder = Depends(get_recorder)) -> StreamingResponse:
    """A recording with all its rotated files (a half: ``game.mcap``, ``game_001.mcap`` ...) as one zip, streamed
    as it is read (files stored as they are: MCAP chunks are compressed already). By the first file's bare name."""
    try:
        first = recorder.files.resolve(name)
    except LogError as exc:
        raise HTTPException(404, str(exc)) from None
    parts = log_series(first)
    if {str(p) for p in parts} & recorder.active_paths():
        raise HTTPException(409, f"{first.name} is still being recorded; download it when it has stopped")
    return StreamingResponse(_zipped(parts), media_type="application/zip",
                             headers={"Content-Disposition": f'attachment; filename="{first.stem}.zip"'})


class _Outbox(io.RawIOBase):
    """Where the zip writer puts its bytes until the response takes them; not seekable, so zipfile streams."""

    def __init__(self) -> None:
        self._parts: list[bytes] = []

    def writable(self) -> bool:
        return True

    def write(self, data: Any) -> int:
        self._parts.append(bytes(data))
        return len(data)

    def take(self) -> bytes:
        out = b"".join(self._parts)
        self._parts.clear()
        return out


def _zipped(parts: list[Path], chunk: int = 1 << 20) -> Iterator[bytes]:
    """The zip of ``parts``, a megabyte at a time (memory stays flat however large the half)."""
    outbox = _Outbox()
    with zipfile.ZipFile(outbox, "w", zipfile.ZIP_STORED) as archive:
        for path in parts:
            with path.open("rb") as source, archive.open(zipfile.ZipInfo.from_file(path, path.name), "w",
                                                         force_zip64=True) as entry:
                while data := source.read(chunk):
                    entry.write(data)
                    yield outbox.take()
    yield outbox.take()


@router.get("/status", response_model=RecorderStatus)
def recording_status(recorder: AnyRecorder = Depends(get_recorder)) -> dict[str, Any]:
    return recorder.status()


@router.post("/start", dependencies=[Depends(require_token)], response_model=Recording)
async def start_recording(request: StartRequest | None = None, recorder: AnyRecorder = Depends(get_recorder)
                          ) -> dict[str, Any]:
    """409 if a manual recording runs already (server.http_errors)."""
    status = await recorder.start_manual((request or StartRequest()).name)
    return status.as_dict()


@router.post("/stop", dependencies=[Depends(require_token)], response_model=Recording)
async def stop_recording(recorder: AnyRecorder = Depends(get_recorder)) -> dict[str, Any]:
    status = await recorder.stop_manual()
    if status is None:
        raise HTTPException(409, "no manual recording is running")
    return status.as_dict()


@router.post("/bookmark", dependencies=[Depends(require_token)])
async def add_bookmark(request: BookmarkRequest, recorder: AnyRecorder = Depends(get_recorder)) -> Bookmarked:
    """409 when nothing is being recorded (server.http_errors)."""
    return Bookmarked(recordings=await recorder.mark(request.name, request.data))
