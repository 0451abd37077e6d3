"""The recorder process on a disk that fills up or is read-only (a small tmpfs, mounted by the test as root, as CI
runs): a clear error in its status (the page's banner), what it has is kept and opens, nothing is corrupt or
doubled, and recording goes on once the disk takes data again."""

from __future__ import annotations

import contextlib
import os
import secrets
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

from robot_nodes.runtime import BusConfig
from schemas.logs import LogReader
from server.recording.service import RECORDER_TOKEN_ENV
from tests.running_recorder import answers, control, recorder_processes
from tests.support import free_port
from tests.teststand import TestStand
from tests.waiting import wait_for

DISK_BYTES = 8 << 20


@contextlib.contextmanager
def small_disk(where: Path, read_only: bool = False) -> Iterator[Path]:
    """A tmpfs of DISK_BYTES at ``where`` (skips the test where mounting is not allowed)."""
    where.mkdir()
    options = f"size={DISK_BYTES}" + (",ro" if read_only else "")
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(where)], capture_output=True)
    if mounted.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here (needs root): {mounted.stderr.decode().strip()}")
    try:
        yield where
    finally:
        subprocess.run(["umount", "-l", str(where)], check=False)


def recorded_sequences(files: list[str]) -> list[int]:
    """The TestStand's sequence numbers (first joint position) of every file, in order; every file must open."""
    seqs: list[int] = []
    for name in files:
        if not Path(name).exists():
            continue
        with LogReader(name) as log:
            seqs += [int(m.msg.position[0]) for m in log.messages(topics=["joint_states"])]
    return seqs


@pytest.fixture
def recorder_control(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[int, str]:
    token = secrets.token_urlsafe(12)
    monkeypatch.setenv(RECORDER_TOKEN_ENV, token)
    return free_port(), token


def recorder_args(router_endpoint: str, folder: Path, port: int) -> list[str]:
    return ["--connect", router_endpoint, "--no-telemetry", "--recordings", str(folder), "--control-port", str(port),
            "--no-auto-record"]


@pytest.mark.timeout(180)
def test_a_full_disk_pauses_the_recording_keeps_its_file_and_resumes_when_space_returns(
        router_endpoint: str, bus: BusConfig, tmp_path: Path, recorder_control: tuple[int, str]) -> None:
    port, token = recorder_control
    node = TestStand("r1", bus, overrides={"rate_hz": 200.0}).start()
    try:
        with small_disk(tmp_path / "disk") as disk, \
                recorder_processes(recorder_args(router_endpoint, disk, port), tmp_path):
            wait_for(lambda: answers(port, token), timeout=60, interval=0.1, what="the recorder up")
            filler = disk / "filler"
            filler.write_bytes(b"\0" * (DISK_BYTES - (96 << 10)))  # leaves about 96 KB
            control(port, token, "/start", "POST")
            full = wait_for(lambda: (m := control(port, token)["manual"]) and m["error"] and m, timeout=60,
                            interval=0.1, what="the disk full")
            assert "No space left on device" in full["error"] and full["running"]
            # what it has opens (complete chunks), and it holds messages
            kept = recorded_sequences(full["files"])
            assert kept and kept == sorted(set(kept))
            lost_before = control(port, token)["manual"]["lost_to_disk"]
            wait_for(lambda: control(port, token)["manual"]["lost_to_disk"] > lost_before, timeout=10,
                     what="messages counted as lost while full")
            os.unlink(filler)  # space returns
            back = wait_for(lambda: (m := control(port, token)["manual"]) and not m["error"] and len(m["files"]) == 2
                            and m, timeout=30, interval=0.1, what="recording again")
            wait_for(lambda: control(port, token)["manual"]["messages"] > back["messages"] + 100, timeout=30,
                     what="messages written again")
            stopped = control(port, token, "/stop", "POST")
            seqs = recorded_sequences(stopped["files"])
    finally:
        node.shutdown()
    assert len(seqs) == len(set(seqs)) and seqs == sorted(seqs), "a message doubled or out of order"
    assert seqs[-1] - seqs[0] + 1 > len(seqs)  # the gap while the disk was full: lost, not invented
    assert len(seqs) > len(kept) + 40  # written again after the space returned (joint_states: half the messages)


@pytest.mark.timeout(180)
def test_a_read_only_folder_is_said_and_recording_starts_once_it_is_writable(
        router_endpoint: str, bus: BusConfig, tmp_path: Path, recorder_control: tuple[int, str]) -> None:
    port, token = recorder_control
    node = TestStand("r1", bus, overrides={"rate_hz": 100.0}).start()
    try:
        with small_disk(tmp_path / "disk", read_only=True) as disk, \
                recorder_processes(recorder_args(router_endpoint, disk, port), tmp_path):
            wait_for(lambda: answers(port, token), timeout=60, interval=0.1, what="the recorder up")
            started = control(port, token, "/start", "POST")
            refused = wait_for(lambda: (m := control(port, token)["manual"]) and m["error"] and m, timeout=30,
                               interval=0.1, what="the read-only folder said")
            assert "Read-only file system" in refused["error"] and started["running"]
            assert not list(disk.glob("*.mcap"))  # no half-made file
            subprocess.run(["mount", "-o", "remount,rw", str(disk)], check=True)
            wait_for(lambda: (m := control(port, token)["manual"]) and not m["error"] and m["messages"] > 100,
                     timeout=30, interval=0.1, what="recording once writable")
            stopped = control(port, token, "/stop", "POST")
            seqs = recorded_sequences(stopped["files"])  # while the disk is mounted
    finally:
        node.shutdown()
    assert len(seqs) > 40 and seqs == sorted(set(seqs)), stopped
