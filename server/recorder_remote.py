"""RemoteRecorder: the dashboard's handle on the recorder process (server.recording.service).

The routers use it as they use the in-process Recorder (start, stop, bookmark, status, the folder's listing). It
asks the recorder's control API on loopback with the recorder's token, and polls its status every POLL_S, so the
page knows within a fraction of a second when the recorder is down (a crash: its supervisor has it back within a
second) and when it came back as a new process (``restarts``). While the dashboard itself restarts, nothing here
matters to the recording: the recorder goes on alone.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from pathlib import Path
from typing import Any

import httpx

from server.recorder import RecorderError
from server.recording.files import RecordingsFolder

log = logging.getLogger(__name__)
logging.getLogger("httpx").setLevel(logging.WARNING)  # a status request every POLL_S is no news for the log

POLL_S = 0.25
REQUEST_TIMEOUT_S = 5.0


class RemoteStatus:
    """A recording's status as the recorder process reported it (the shape of RecordingStatus.as_dict)."""

    def __init__(self, data: dict[str, Any]) -> None:
        self.data = data

    @property
    def name(self) -> str:
        return str(self.data.get("name", ""))

    def as_dict(self) -> dict[str, Any]:
        return self.data


class RemoteRecorder:
    """Talks to the recorder at ``url`` (http://127.0.0.1:PORT); ``folder`` is the recordings folder both share."""

    def __init__(self, url: str, token: str, folder: Path, auto_match: bool = True) -> None:
        self.url = url.rstrip("/")
        self.folder = Path(folder)
        self.files = RecordingsFolder(self.folder)
        self.auto_match = auto_match
        self._headers = {"Authorization": f"Bearer {token}"}
        self._client: httpx.AsyncClient | None = None
        self._poll_task: asyncio.Task[None] | None = None
        self._last: dict[str, Any] = {}
        self.up = False
        self.down_since: float | None = time.time()  # until the first answer
        self.pid: int | None = None
        self.restarts = 0  # new recorder processes seen since this dashboard started
        self.outages: list[dict[str, float]] = []  # {"from", "to", "down_s"}: while the recorder was down

    async def start(self) -> None:
        self._client = httpx.AsyncClient(base_url=self.url, headers=self._headers, timeout=REQUEST_TIMEOUT_S)
        with contextlib.suppress(RecorderError):
            await self._refresh()
        self._poll_task = asyncio.get_running_loop().create_task(self._poll())

    async def close(self) -> None:
        if self._poll_task is not None:
            self._poll_task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._poll_task
            self._poll_task = None
        if self._client is not None:
            await self._client.aclose()
            self._client = None

    async def _poll(self) -> None:
        while True:
            await asyncio.sleep(POLL_S)
            with contextlib.suppress(RecorderError):
                await self._refresh()

    async def _refresh(self) -> dict[str, Any]:
        status = await self._call("GET", "/status")
        self._last = status
        pid = status.get("pid")
        if self.pid is not None and pid != self.pid:
            self.restarts += 1
            log.warning("the recorder was restarted (pid %s -> %s)", self.pid, pid)
        self.pid = pid
        return status

    async def _call(self, method: str, path: str, body: dict[str, Any] | None = None) -> Any:
        if self._client is None:
            raise RecorderError("the recorder is not connected")
        try:
            response = await self._client.request(method, path, json=body)
        except httpx.HTTPError as exc:
            self._went_down()
            raise RecorderError(f"the recorder process does not answer (it is restarted within a second): "
                                f"{exc.__class__.__name__}") from None
        self._came_up()
        if response.status_code >= 400:
            try:
                detail = response.json().get("detail", response.text)
            except ValueError:
                detail = response.text
            raise RecorderError(str(detail))
        return response.json()

    def _went_down(self) -> None:
        if self.up or self.down_since is None:
            self.up = False
            self.down_since = time.time()
            log.warning("the recorder process does not answer")

    def _came_up(self) -> None:
        if not self.up:
            now = time.time()
            if self.down_since is not None and self.pid is not None:  # an outage, not the first start
                self.outages.append({"from": self.down_since, "to": now, "down_s": round(now - self.down_since, 3)})
                self.outages = self.outages[-20:]
            self.up, self.down_since = True, None

    # -- what the routers call ---------------------------------------------------------------------------------
    async def start_manual(self, name: str = "", reason: str = "manual") -> RemoteStatus:
        return RemoteStatus(await self._call("POST", "/start", {"name": name}))

    async def stop_manual(self) -> RemoteStatus | None:
        stopped = await self._call("POST", "/stop")
        return RemoteStatus(stopped) if stopped else None

    async def mark(self, name: str, data: dict[str, Any] | None = None) -> list[str]:
        return list((await self._call("POST", "/bookmark", {"name": name, "data": data}))["recordings"])

    def active_paths(self) -> set[str]:
        return set(self._last.get("active", []))

    def status(self) -> dict[str, Any]:
        last = self._last
        return {"folder": str(self.folder), "auto_match": last.get("auto_match", self.auto_match),
                "manual": last.get("manual"), "match": last.get("match"), "recent": last.get("recent", []),
                "process": {"separate": True, "up": self.up, "down_since": self.down_since, "pid": self.pid,
                            "restarts": self.restarts, "outages": self.outages,
                            "error": (last.get("manual") or last.get("match") or {}).get("error", "")}}

    def listing(self) -> list[dict[str, Any]]:
        return self.files.listing(self.active_paths())
