"""The command line: `pitchside replay FILE`, `pitchside record`, `pitchside export-rerun` (real processes)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import httpx
import pytest

from tests.support import REPO, free_port
from tests.test_replay import _pitchside_log
from tests.waiting import wait_for


def _cli(*args: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "pitchside.cli", *args], cwd=REPO, capture_output=True, text=True,
                          timeout=timeout, env=dict(os.environ, PYTHONUNBUFFERED="1"))


def test_pitchside_replay_and_record(tmp_path: Path) -> None:
    log = tmp_path / "game.mcap"
    _pitchside_log(log, seconds=4.0)
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    out = (tmp_path / "server.log").open("wb")
    process = subprocess.Popen([sys.executable, "-m", "pitchside.cli", "replay", str(log), "--port", str(port),
                                "--recordings", str(tmp_path / "rec")], cwd=REPO, stdout=out,
                               stderr=subprocess.STDOUT)

    def opened() -> bool:
        assert process.poll() is None, (tmp_path / "server.log").read_text()
        try:
            return httpx.get(f"{url}/api/replay", timeout=1).json().get("state") == "paused"
        except httpx.HTTPError:
            return False

    try:
        wait_for(opened, timeout=60, interval=0.2, what="replay server with the file open")
        info = httpx.get(f"{url}/api/replay/info").json()
        assert info["robots"] == ["replay.r1", "replay.r2"] and info["path"] == str(log)
        assert httpx.get(f"{url}/api/sources").json()[0]["running"] is False  # no live source next to a replay
        started = _cli("record", "start", "cli test", "--server", url)
        assert started.returncode == 0, started.stderr
        assert "recording" in started.stdout
        assert "recording" in _cli("record", "status", "--server", url).stdout
        stopped = _cli("record", "stop", "--server", url)
        assert stopped.returncode == 0 and "stopped" in stopped.stdout, stopped.stderr
        listed = _cli("record", "list", "--server", url).stdout
        assert "_cli_test.mcap" in listed
        again = _cli("record", "stop", "--server", url)
        assert again.returncode != 0 and "no manual recording" in again.stderr
    finally:
        process.terminate()
        process.wait(15)
    refused = _cli("record", "status", "--server", url)
    assert refused.returncode != 0 and "no dashboard server" in refused.stderr


def test_export_rerun_of_a_foreign_bag(testdata: Path, tmp_path: Path) -> None:
    out = tmp_path / "cdr.rrd"
    done = _cli("export-rerun", str(testdata / "mcap" / "cdr_test_0.mcap"), "-o", str(out))
    assert done.returncode == 0, done.stderr
    assert "from 7 messages" in done.stdout and out.stat().st_size > 1000
    printed = subprocess.run([str(Path(sys.executable).parent / "rerun"), "rrd", "print", str(out)],
                             capture_output=True, text=True, timeout=60).stdout
    assert "with 3 rows" in next(line for line in printed.splitlines() if line.endswith(
        "/replay/test_topic/int32_value - data columns: [Scalars:scalars]"))


def test_export_rerun_names_joints(tmp_path: Path) -> None:
    import schemas
    from schemas.numeric import numeric_fields

    msg = schemas.make("sensor_msgs/msg/JointState", name=["head_pan", "head_tilt"], position=[0.1, 0.2],
                       velocity=[], effort=[])
    fields = dict(numeric_fields(msg))
    assert fields == {"position/head_pan": 0.1, "position/head_tilt": 0.2}
    bad = _cli("export-rerun", str(tmp_path / "missing.mcap"))
    assert bad.returncode != 0 and "no log files" in bad.stderr


def test_export_rerun_writes_as_it_reads_and_shows_progress(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Scalars go to the .rrd in pieces while the log is read (memory stays flat; bench/export_rerun.py measures
    it on 1 GB), none lost on the way; the command's progress goes to stderr, its result to stdout."""
    from pitchside import export_rerun

    log = tmp_path / "game.mcap"
    _pitchside_log(log, seconds=4.0)  # 200 joint states per robot
    monkeypatch.setattr(export_rerun, "FLUSH_SCALARS", 150)
    monkeypatch.setattr(export_rerun, "PROGRESS_EVERY", 50)
    seen: list[float] = []
    counts = export_rerun.export(log, tmp_path / "pieces.rrd", on_progress=seen.append)
    assert counts["messages"] == 404 and counts["bookmarks"] == 0
    assert seen == sorted(seen) and seen[-1] == 1.0 and len(seen) >= 5
    rows = _rows_per_chunk(tmp_path / "pieces.rrd", "/r1/joint_states/position/head_pan")
    assert len(rows) >= 2 and sum(rows) == 200, rows  # in pieces, every scalar there

    done = _cli("export-rerun", str(log), "-o", str(tmp_path / "cli.rrd"))
    assert done.returncode == 0, done.stderr
    assert "export-rerun: 100%" in done.stderr
    assert done.stdout.strip().splitlines() == [f"{tmp_path / 'cli.rrd'}: {counts['series']} series, "
                                                f"{counts['scalars']} scalars from 404 messages, 0 bookmarks"]
    quiet = _cli("export-rerun", str(log), "-o", str(tmp_path / "quiet.rrd"), "--quiet")
    assert quiet.returncode == 0 and quiet.stderr == ""


def _rows_per_chunk(rrd: Path, entity: str) -> list[int]:
    printed = subprocess.run([str(Path(sys.executable).parent / "rerun"), "rrd", "print", str(rrd)],
                             capture_output=True, text=True, timeout=60).stdout
    return [int(line.rsplit("with ", 1)[1].split()[0]) for line in printed.splitlines()
            if f" {entity} - data columns" in line]
