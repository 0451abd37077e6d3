"""A half's files at once: a size-rotated recording (``half.mcap``, ``half_001.mcap`` ...) downloads from the
dashboard as one zip, streamed, through the venue guard and only from the recordings folder; the page offers it."""

from __future__ import annotations

import io
import os
import zipfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest

import schemas
from schemas.logs import LogWriter, log_series
from schemas.std import CompressedImage
from tests.dashboard_server import RunningServer, dashboard_server

EVIL = "http://evil.example"


def _rotated_half(path: Path) -> list[Path]:
    """A recording rotated into several files, with incompressible images so that it does rotate."""
    image = schemas.encode(schemas.make(CompressedImage, format="jpeg", data=np.zeros(20_000, dtype=np.uint8)))
    head = image[:-20_000]
    with LogWriter(path, rotate_bytes=150_000, chunk_size=64_000) as writer:
        for i in range(40):
            writer.write("robot1", "camera/image/compressed", head + os.urandom(20_000),
                         log_time_ns=1_700_000_000_000_000_000 + i * 100_000_000)
    return log_series(path)


@pytest.fixture
def recorded(tmp_path: Path) -> Iterator[tuple[RunningServer, Path, list[Path]]]:
    folder = tmp_path / "rec"
    folder.mkdir()
    parts = _rotated_half(folder / "half.mcap")
    assert len(parts) >= 3
    (tmp_path / "secret.mcap").write_bytes(parts[0].read_bytes())  # beside the folder: never served
    with dashboard_server(["--no-live", "--no-telemetry", "--recordings", str(folder)], tmp_path) as server:
        yield server, folder, parts


def test_a_halfs_files_download_as_one_zip(recorded: tuple[RunningServer, Path, list[Path]]) -> None:
    server, _, parts = recorded
    listing = server.http.get(f"{server.url}/api/recordings", timeout=10).json()
    by_name = {f["name"]: f for f in listing["files"]}
    assert by_name["half.mcap"]["series"] == [p.name for p in parts]
    assert "series" not in by_name[parts[1].name]  # a later part is no half of its own
    with server.http.stream("GET", f"{server.url}/api/recordings/series/half.mcap", timeout=30) as reply:
        assert reply.status_code == 200, reply.read()
        assert reply.headers["content-type"] == "application/zip"
        assert 'filename="half.zip"' in reply.headers["content-disposition"]
        assert "content-length" not in reply.headers  # streamed as it is read, not built in memory first
        body = reply.read()
    with zipfile.ZipFile(io.BytesIO(body)) as archive:
        assert archive.namelist() == [p.name for p in parts]
        assert archive.testzip() is None
        for part in parts:
            assert archive.read(part.name) == part.read_bytes()


@pytest.mark.parametrize("name", ["nothing.mcap", "notes.txt", "..%2Fsecret.mcap", "%2Fetc%2Fpasswd",
                                  "..%2F..%2Fsecret.mcap"])
def test_only_recordings_of_the_folder(recorded: tuple[RunningServer, Path, list[Path]], name: str) -> None:
    server, folder, _ = recorded
    (folder / "notes.txt").write_text("not a recording")
    assert server.http.get(f"{server.url}/api/recordings/series/{name}", timeout=10).status_code == 404


def test_the_venue_guard_covers_the_zip(recorded: tuple[RunningServer, Path, list[Path]]) -> None:
    server, _, _ = recorded
    url = f"{server.url}/api/recordings/series/half.mcap"
    assert httpx.get(url, headers={"Origin": EVIL}, timeout=10).status_code == 403  # a foreign page reading it
    no_cors = {"Sec-Fetch-Site": "cross-site", "Sec-Fetch-Mode": "no-cors"}
    assert httpx.get(url, headers=no_cors, timeout=10).status_code == 403
    assert httpx.get(url, headers={"Host": "evil.example"}, timeout=10).status_code in (400, 421)  # DNS rebinding


@pytest.mark.browser
def test_the_page_downloads_the_half(browser: Any, recorded: tuple[RunningServer, Path, list[Path]],
                                     tmp_path: Path) -> None:
    server, _, parts = recorded
    page = browser.new_page()
    try:
        page.goto(server.page_url("match"))  # after a match: the recordings are in its layout
        row = page.locator('.rec-files tr[data-file="half.mcap"]')
        row.wait_for(timeout=20_000)
        link = row.locator("a[data-download-series]")
        assert link.inner_text() == f"all {len(parts)} files (zip)"
        with page.expect_download() as download:
            link.click()
        assert download.value.suggested_filename == "half.zip"
        saved = tmp_path / "saved.zip"
        download.value.save_as(saved)
        with zipfile.ZipFile(saved) as archive:
            assert [archive.read(p.name) == p.read_bytes() for p in parts] == [True] * len(parts)
        assert page.locator(f'.rec-files tr[data-file="{parts[1].name}"] a[data-download-series]').count() == 0
    finally:
        page.close()
