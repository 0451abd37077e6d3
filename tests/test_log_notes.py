"""Notes on a log (schemas.logs.notes): kept beside the log, read back in time order, the log itself never touched;
a damaged sidecar is reported and not read, a bad name refused."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

import schemas
from schemas.logs import LogNotes, LogSeriesReader, LogWriter, NotesError, notes_path

T0 = 1_700_000_000_000_000_000


def _log(path: Path) -> None:
    with LogWriter(path) as writer:
        for k in range(10):
            writer.write("r1", "gamestate", schemas.make("humanoid_league_msgs/msg/GameState", game_state=3),
                         log_time_ns=T0 + k * 10**9)
        writer.add_bookmark("PLAYING", log_time_ns=T0)


def test_notes_beside_the_log_survive_and_leave_it_unchanged(tmp_path: Path) -> None:
    log = tmp_path / "half.mcap"
    _log(log)
    before = hashlib.sha256(log.read_bytes()).hexdigest()
    notes = LogNotes(log)
    assert notes.notes == [] and notes.problem == ""
    notes.add("  fell   here ", T0 + 5 * 10**9)
    notes.add("kick too short", T0 + 2 * 10**9)
    assert notes_path(log) == tmp_path / "half.mcap.notes.json" and notes_path(log).is_file()
    again = LogNotes(log)  # another session
    assert [(n.name, n.log_time_ns) for n in again.notes] == [("kick too short", T0 + 2 * 10**9),
                                                              ("fell here", T0 + 5 * 10**9)]
    assert hashlib.sha256(log.read_bytes()).hexdigest() == before
    with LogSeriesReader(log) as reader:  # the log reads as before: its own bookmark only
        assert [b.name for b in reader.bookmarks] == ["PLAYING"]


@pytest.mark.parametrize("name", ["", "   ", "x" * 121])
def test_bad_names_are_refused(tmp_path: Path, name: str) -> None:
    notes = LogNotes(tmp_path / "a.mcap")
    with pytest.raises(NotesError):
        notes.add(name, T0)
    assert not notes_path(tmp_path / "a.mcap").exists()


@pytest.mark.parametrize("content", ["{not json", '{"format": "other", "notes": []}', '{"format":'
                                     ' "pitchside-log-notes", "notes": [{"name": 3}]}', "[1, 2]"])
def test_a_damaged_sidecar_is_reported_not_read(tmp_path: Path, content: str) -> None:
    notes_path(tmp_path / "a.mcap").write_text(content)
    notes = LogNotes(tmp_path / "a.mcap")
    assert notes.notes == [] and "unreadable" in notes.problem


def test_a_sidecar_that_cannot_be_written_is_an_error(tmp_path: Path) -> None:
    notes = LogNotes(tmp_path / "missing-folder" / "a.mcap")
    with pytest.raises(NotesError, match="notes not written"):
        notes.add("here", T0)
