"""Where robot messages enter the server: each source feeds the hub and can be switched on and off."""

from __future__ import annotations

import asyncio
from typing import Any


class SourceError(RuntimeError):
    """A source cannot be switched as asked; the text says why (e.g. match mode)."""


class Source:
    """Base of the live Zenoh, UDP telemetry and replay sources."""

    name = "source"

    def __init__(self) -> None:
        self.running = False
        self.error = ""

    async def start(self) -> None:
        self.running = True

    async def stop(self) -> None:
        self.running = False

    def stream_health(self) -> dict[tuple[str, str], dict[str, Any]]:
        """Extra link figures per (robot, topic) that only the source knows (loss %, budget share)."""
        return {}

    def status(self) -> dict[str, Any]:
        return {"name": self.name, "running": self.running, "error": self.error}


class SourceSet:
    """The sources of one server, by name; switching is serialized so on/off requests cannot interleave."""

    def __init__(self, sources: list[Source]) -> None:
        self.sources = {s.name: s for s in sources}
        self._lock = asyncio.Lock()

    def __getitem__(self, name: str) -> Source:
        try:
            return self.sources[name]
        except KeyError:
            raise SourceError(f"no source {name!r} (have {sorted(self.sources)})") from None

    async def switch(self, name: str, on: bool) -> Source:
        source = self[name]
        async with self._lock:
            if on and not source.running:
                await source.start()
            elif not on and source.running:
                await source.stop()
        return source

    async def stop_all(self) -> None:
        for source in self.sources.values():
            if source.running:
                await source.stop()

    def stream_health(self) -> dict[tuple[str, str], dict[str, Any]]:
        merged: dict[tuple[str, str], dict[str, Any]] = {}
        for source in self.sources.values():
            if source.running:
                for key, figures in source.stream_health().items():
                    merged.setdefault(key, {}).update(figures)
        return merged
