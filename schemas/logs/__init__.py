"""MCAP logs of pitchside: writing per-robot channels, reading pitchside logs and ROS 2 bags."""

from schemas.logs.naming import BOOKMARK_TOPIC, LogError, channel_topic, log_series, rotated_path
from schemas.logs.notes import LogNotes, NotesError, notes_path
from schemas.logs.reader import Bookmark, ChannelInfo, LogMessage, LogReader
from schemas.logs.series import LogSeriesReader
from schemas.logs.source import LogSource
from schemas.logs.timeline import data_start_ns
from schemas.logs.writer import LogWriter

__all__ = [
    "BOOKMARK_TOPIC",
    "Bookmark",
    "ChannelInfo",
    "LogError",
    "LogMessage",
    "LogNotes",
    "LogReader",
    "LogSeriesReader",
    "LogSource",
    "LogWriter",
    "NotesError",
    "channel_topic",
    "data_start_ns",
    "log_series",
    "notes_path",
    "rotated_path",
]
