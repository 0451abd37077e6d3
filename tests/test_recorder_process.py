"""The recorder as its own process (server.recording.service): the dashboard dies, the recording goes on untouched;
the recorder dies, its warm spare goes on within the bound and the recording shows the gap. Real processes, real
Zenoh, real files."""

from __future__ import annotations

import os
import secrets
import signal
import time
from pathlib import Path

import httpx
import pytest

from robot_nodes.runtime import BusConfig
from schemas.logs import LogSeriesReader
from server.recorder import GAP_BOOKMARK
from server.recording.service import RECORDER_TOKEN_ENV
from server.recording.session import CRASH_LOSS_BOUND_S
from tests.dashboard_server import dashboard_server
from tests.running_recorder import answers, control, recorder_processes
from tests.support import free_port
from tests.teststand import TestStand
from tests.waiting import wait_for


@pytest.mark.realtime
@pytest.mark.timeout(240)
def test_recording_survives_a_dashboard_crash_and_a_recorder_crash_costs_its_buffer(
        router_endpoint: str, bus: BusConfig, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    folder = tmp_path / "rec"
    token = secrets.token_urlsafe(12)
    monkeypatch.setenv(RECORDER_TOKEN_ENV, token)
    control_port = free_port()
    common = ["--connect", router_endpoint, "--no-telemetry", "--recordings", str(folder), "--no-foxglove"]
    recorder_args = [*common, "--control-port", str(control_port), "--standby-lock", str(tmp_path / "rec.lock")]
    dashboard_args = [*common, "--recorder", f"http://127.0.0.1:{control_port}"]
    node = TestStand("r1", bus, overrides={"rate_hz": 100.0}).start()
    try:
        with recorder_processes(recorder_args, tmp_path, copies=2) as (first, spare):
            wait_for(lambda: answers(control_port, token), timeout=60, interval=0.1, what="the recorder up")
            # the control API: loopback only, and only with the token
            refused = httpx.get(f"http://127.0.0.1:{control_port}/status", timeout=5)
            assert refused.status_code == 401
            wrong = httpx.get(f"http://127.0.0.1:{control_port}/status", timeout=5,
                              headers={"Authorization": "Bearer nope", "Host": "evil.example"})
            assert wrong.status_code == 421
            with dashboard_server(dashboard_args, tmp_path) as dash:
                started = dash.http.post(f"{dash.url}/api/recordings/start", json={"name": "lab"})
                assert started.is_success, started.text
                wait_for(lambda: control(control_port, token)["manual"]["messages"] >= 100, timeout=30,
                         interval=0.05, what="recording")
                os.kill(dash.process.pid, signal.SIGKILL)
                dash.process.wait(10)
                dashboard_killed = control(control_port, token)["manual"]["messages"]
            # the dashboard is gone: the recorder records on, in the same file
            wait_for(lambda: control(control_port, token)["manual"]["messages"] >= dashboard_killed + 100,
                     timeout=30, interval=0.05, what="recording without the dashboard")
            with dashboard_server(dashboard_args, tmp_path) as dash:
                status = dash.http.get(f"{dash.url}/api/recordings/status").json()
                assert status["manual"]["name"].endswith("_lab") and not status["manual"]["resumed"]
                assert status["process"]["up"] and status["process"]["pid"] == first.pid
                file = Path(status["manual"]["files"][0])
                size = file.stat().st_size
                wait_for(lambda: file.stat().st_size > size, timeout=30, what="a chunk written")
                time.sleep(2 * CRASH_LOSS_BOUND_S)  # the kill comes well after that chunk
                killed_at = time.time()
                os.kill(first.pid, signal.SIGKILL)
                wait_for(lambda: (s := answers(control_port, token)) and s["pid"] == spare.pid
                                and s["manual"] and s["manual"]["resumed"] and s, timeout=60, interval=0.02,
                                what="the spare recorder going on with the recording")
                back_s = time.time() - killed_at
                seen = wait_for(lambda: (s := dash.http.get(f"{dash.url}/api/recordings/status").json())
                                ["process"]["restarts"] == 1 and s, timeout=10, interval=0.05,
                                what="the dashboard seeing the new recorder")
                assert seen["process"]["up"] and seen["process"]["pid"] == spare.pid
                wait_for(lambda: control(control_port, token)["manual"]["messages"] >= 100, timeout=30,
                         interval=0.05, what="recording in the spare")
                assert dash.http.post(f"{dash.url}/api/recordings/stop").is_success
    finally:
        node.shutdown()
    print(f"recorder back (the spare recording) {back_s:.2f} s after its kill")
    (first_file,) = folder.glob("*_lab.mcap")
    with LogSeriesReader(first_file) as log:
        assert [p.name for p in log.paths] == [first_file.name, f"{first_file.stem}_001.mcap"]
        recorded = [(m.log_time_ns / 1e9, int(m.msg.position[0])) for m in log.messages(topics=["joint_states"])]
        gaps = [b for b in log.bookmarks if b.name == GAP_BOOKMARK]
    before = [(t, seq) for t, seq in recorded if t < killed_at]
    # across the dashboard's crash and restart nothing is missing: every sequence number until the recorder's kill
    seqs = [seq for _, seq in before]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs))), "a message missing while the dashboard was down"
    # the recorder's crash lost at most its unflushed buffer
    assert before[-1][0] >= killed_at - CRASH_LOSS_BOUND_S, killed_at - before[-1][0]
    # and the resumed file says where the hole is and how long
    (gap,) = gaps
    assert before[-1][0] - 0.01 <= gap.log_time_ns / 1e9 <= killed_at  # after the last message the cut file kept
    first_after = min(t for t, _ in recorded if t > killed_at)
    assert 0 < gap.data["gap_s"] <= first_after - before[-1][0] + 0.5
