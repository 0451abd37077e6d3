"""The stable import path of pitchside's MCAP logs (implementation in schemas/logs/)."""

from schemas.logs import (
    BOOKMARK_TOPIC,
    Bookmark,
    ChannelInfo,
    LogError,
    LogMessage,
    LogReader,
    LogSeriesReader,
    LogWriter,
    channel_topic,
    log_series,
    rotated_path,
)

__all__ = [
    "BOOKMARK_TOPIC",
    "Bookmark",
    "ChannelInfo",
    "LogError",
    "LogMessage",
    "LogReader",
    "LogSeriesReader",
    "LogWriter",
    "channel_topic",
    "log_series",
    "rotated_path",
]
