"""What every log reader offers (one file, a rotated series): the surface replay and the tools rely on."""

from __future__ import annotations

from collections.abc import Collection, Iterator
from typing import Protocol

from schemas.logs.reader import Bookmark, ChannelInfo, LogMessage


class LogSource(Protocol):
    """Facts about a log are properties; reading its messages is a method."""

    @property
    def channels(self) -> list[ChannelInfo]: ...
    @property
    def topics(self) -> dict[str, str]: ...
    @property
    def robots(self) -> list[str]: ...
    @property
    def bookmarks(self) -> list[Bookmark]: ...
    @property
    def message_count(self) -> int: ...
    @property
    def start_ns(self) -> int: ...
    @property
    def end_ns(self) -> int: ...
    @property
    def duration(self) -> float: ...

    def messages(self, start_ns: int | None = None, end_ns: int | None = None,
                 topics: Collection[str] | None = None, robots: Collection[str] | None = None,
                 decode: bool = True) -> Iterator[LogMessage]: ...

    def close(self) -> None: ...
