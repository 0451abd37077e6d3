"""The recorder: what the hub sees goes into MCAP (real server, real Zenoh), matches per half, kill -9 safety."""

from __future__ import annotations

import asyncio
import os
import signal
import time
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest

import schemas
from robot_nodes.runtime import BusConfig, Node
from schemas.logs import LogReader, LogSeriesReader
from server.hub import Hub, HubMessage
from server.recorder import Recorder
from server.recording.game_events import FINISHED, INITIAL, PLAYING, READY, SET, GameEvents
from server.recording.journal import JOURNAL_NAME, RESUME_WITHIN_S, RecordingJournal
from server.recording.session import CRASH_LOSS_BOUND_S
from tests.dashboard_server import dashboard_server
from tests.teststand import TestStand
from tests.waiting import wait_for

GS = "humanoid_league_msgs/msg/GameState"


def gamestate(state: int, first_half: bool = True, own: int = 0, rival: int = 0, penalized: bool = False,
              colour: int = 0) -> Any:
    return schemas.make(GS, game_state=state, first_half=first_half, own_score=own, rival_score=rival,
                        penalized=penalized, seconds_till_unpenalized=30 if penalized else 0, team_color=colour)


# -- game events (pure) -----------------------------------------------------------------------------------
def test_game_events_start_split_stop_and_bookmarks() -> None:
    events = GameEvents()
    kinds = lambda evs: [(e.kind, e.part or e.name) for e in evs]  # noqa: E731
    assert events.feed("r1", gamestate(INITIAL)) == []
    assert events.feed("r2", gamestate(INITIAL)) == []
    assert kinds(events.feed("r1", gamestate(READY))) == [("start", "half1"), ("bookmark", "READY")]
    assert events.feed("r2", gamestate(READY)) == []  # the same change from the second robot: nothing new
    assert kinds(events.feed("r1", gamestate(PLAYING))) == [("bookmark", "PLAYING")]
    assert kinds(events.feed("r2", gamestate(SET))) == []  # r2 lags behind: the game does not go back
    assert kinds(events.feed("r2", gamestate(PLAYING, penalized=True))) == [("bookmark", "penalty r2")]
    assert kinds(events.feed("r1", gamestate(READY, own=1))) == [("bookmark", "goal own 1:0"),
                                                                 ("bookmark", "READY")]
    assert kinds(events.feed("r1", gamestate(INITIAL, first_half=False, own=1))) == [
        ("bookmark", "INITIAL"), ("stop", "half1")]
    assert kinds(events.feed("r1", gamestate(READY, first_half=False, own=1))) == [
        ("start", "half2"), ("bookmark", "READY")]
    assert kinds(events.feed("r1", gamestate(PLAYING, first_half=False, own=1, rival=1)))[0] == (
        "bookmark", "goal rival 1:1")
    assert kinds(events.feed("r1", gamestate(FINISHED, first_half=False, own=1, rival=1))) == [
        ("bookmark", "FINISHED"), ("stop", "half2")]


def test_game_events_of_two_teams_tell_one_score() -> None:
    """Robots of both teams (a simulated match): each tells the score from its side; one game, one goal each."""
    events = GameEvents()
    kinds = lambda evs: [(e.kind, e.part or e.name) for e in evs]  # noqa: E731
    blue, red = 0, 1
    assert events.feed("home1", gamestate(INITIAL, colour=blue)) == []
    assert events.feed("away1", gamestate(INITIAL, colour=red)) == []
    assert kinds(events.feed("away1", gamestate(READY, colour=red))) == [("start", "half1"), ("bookmark", "READY")]
    assert events.feed("home1", gamestate(READY, colour=blue)) == []
    events.feed("home1", gamestate(PLAYING, colour=blue))
    assert events.feed("away1", gamestate(PLAYING, colour=red)) == []
    # red scores: red's robot says own 1, blue's says rival 1; one bookmark, named by the scorer's colour
    assert kinds(events.feed("away1", gamestate(READY, own=1, colour=red))) == [("bookmark", "goal red 0:1"),
                                                                               ("bookmark", "READY")]
    assert events.feed("home1", gamestate(READY, rival=1, colour=blue)) == []
    assert events.feed("away1", gamestate(READY, own=1, colour=red)) == []  # the same again: nothing
    events.feed("home1", gamestate(PLAYING, rival=1, colour=blue))
    assert kinds(events.feed("home1", gamestate(READY, own=1, rival=1, colour=blue))) == [
        ("bookmark", "goal blue 1:1"), ("bookmark", "READY")]
    assert events.feed("away1", gamestate(READY, own=1, rival=1, colour=red)) == []
    assert kinds(events.feed("away1", gamestate(FINISHED, own=1, rival=1, colour=red))) == [
        ("bookmark", "FINISHED"), ("stop", "half1")]
    red_first = GameEvents()  # whoever is heard first, a goal's score reads blue:red
    red_first.feed("away1", gamestate(PLAYING, colour=red))
    red_first.feed("home1", gamestate(PLAYING, colour=blue))
    assert kinds(red_first.feed("home1", gamestate(READY, own=1, colour=blue))) == [
        ("start", "half1"), ("bookmark", "goal blue 1:0"), ("bookmark", "READY")]


def test_game_events_first_half_to_second_without_initial_splits() -> None:
    events = GameEvents()
    assert events.feed("r1", gamestate(PLAYING)) == []  # joined a running game: not seen leaving INITIAL
    assert events.recording_part is None
    events.feed("r1", gamestate(INITIAL))
    events.feed("r1", gamestate(PLAYING))
    assert events.recording_part == "half1"
    out = events.feed("r1", gamestate(READY, first_half=False))
    assert (out[0].kind, out[0].part) == ("split", "half2")


def test_game_events_resume_after_a_restart_while_the_game_is_on() -> None:
    kinds = lambda evs: [(e.kind, e.part or e.name) for e in evs]  # noqa: E731
    on = GameEvents()
    on.resume("half1")
    assert kinds(on.feed("r1", gamestate(PLAYING))) == [("resume", "half1")]  # joined a running game, yet records
    assert on.recording_part == "half1"
    assert kinds(on.feed("r1", gamestate(INITIAL, first_half=False))) == [("bookmark", "INITIAL"), ("stop", "half1")]
    over = GameEvents()
    over.resume("half1")
    assert kinds(over.feed("r1", gamestate(INITIAL, first_half=False))) == [("stop", "half1")]  # half time came
    assert over.recording_part is None
    later = GameEvents()
    later.resume("half1")
    assert kinds(later.feed("r1", gamestate(READY, first_half=False))) == [("resume", "half2")]


# -- automatic match recording through a real hub -----------------------------------------------------------
def test_match_recording_per_half_with_bookmarks(tmp_path: Path) -> None:
    async def main() -> None:
        hub = Hub()
        hub.bind(asyncio.get_running_loop())
        recorder = Recorder(hub, tmp_path)
        await recorder.start()
        seq = 0

        async def play(state: int, first_half: bool = True, own: int = 0, penalized: bool = False) -> None:
            nonlocal seq
            for robot in ("r1", "r2"):
                msg = gamestate(state, first_half, own, penalized=penalized and robot == "r2")
                hub.publish(HubMessage(robot, "gamestate", GS, time.time(), schemas.encode(msg), "live"))
            await asyncio.sleep(0.05)  # the recorder's tasks run
            for _ in range(5):
                seq += 1
                joints = schemas.make("sensor_msgs/msg/JointState", name=["a"], position=[float(seq)])
                hub.publish(HubMessage("r1", "joint_states", joints.__msgtype__, time.time(),
                                       schemas.encode(joints), "live"))
            await asyncio.sleep(0.05)

        await play(INITIAL)
        assert recorder.match is None
        await play(READY)
        assert recorder.match is not None and recorder.match.path.name.endswith("_half1.mcap")
        await play(PLAYING)
        await play(PLAYING, penalized=True)
        await play(READY, own=1)
        await play(INITIAL, first_half=False, own=1)
        assert recorder.match is None  # half time
        await play(READY, first_half=False, own=1)
        assert recorder.match is not None and recorder.match.path.name.endswith("_half2.mcap")
        await play(FINISHED, first_half=False, own=1)
        assert recorder.match is None
        await recorder.close()

    asyncio.run(main())
    half1, half2 = sorted(tmp_path.glob("match-*_half*.mcap"))
    assert half1.name.split("_")[0] == half2.name.split("_")[0]  # one match id
    with LogReader(half1) as log:
        assert log.indexed
        marks = [b.name for b in log.bookmarks]
        assert marks == ["READY", "PLAYING", "penalty r2", "goal own 1:0", "READY", "unpenalized r2", "INITIAL"]
        positions = [m.msg.position[0] for m in log.messages(topics=["joint_states"])]
        assert positions == sorted(positions) and len(positions) >= 20
        assert {c.robot_id for c in log.channels if c.topic == "gamestate"} == {"r1", "r2"}
    with LogReader(half2) as log:
        assert [b.name for b in log.bookmarks] == ["READY", "FINISHED"]
        assert log.message_count > 5


# -- a real server: REST start/stop, listing; kill -9 ----------------------------------------------------------
@pytest.fixture
def stand(bus: BusConfig) -> Any:
    node = TestStand("r1", bus, overrides={"rate_hz": 50.0, "image_hz": 30.0}).start()
    yield node
    node.shutdown()


def _status(url: str) -> dict[str, Any]:
    return httpx.get(f"{url}/api/recordings/status", timeout=5).json()


def test_rest_recording_of_live_messages(router_endpoint: str, stand: TestStand, tmp_path: Path) -> None:
    folder = tmp_path / "rec"
    with dashboard_server(["--connect", router_endpoint, "--no-telemetry", "--recordings", str(folder)],
                          tmp_path) as server:
        started = server.http.post(f"{server.url}/api/recordings/start", json={"name": "lab test"}, timeout=10)
        assert started.status_code == 200, started.text
        assert server.http.post(f"{server.url}/api/recordings/start", json={}, timeout=10).status_code == 409
        # 200 of all topics: at least 40 of them joint_states, whatever else the stand's nodes say (rosout, ...)
        wait_for(lambda: (_status(server.url)["manual"] or {}).get("messages", 0) >= 200, timeout=30,
                 interval=0.2, what="200 messages recorded")
        assert server.http.post(f"{server.url}/api/recordings/bookmark", json={"name": "fell"}).status_code == 200
        stopped = server.http.post(f"{server.url}/api/recordings/stop", timeout=20).json()
        assert stopped["running"] is False and stopped["messages"] >= 100
        listing = server.http.get(f"{server.url}/api/recordings", timeout=10).json()
        # the file downloads as it is on disk; nothing else of the machine does
        got = server.http.get(f"{server.url}/api/recordings/files/{listing['files'][0]['name']}", timeout=20)
        assert got.status_code == 200 and "attachment" in got.headers["content-disposition"]
        (folder / "notes.txt").write_text("not a recording")
        (tmp_path / "elsewhere.mcap").write_bytes(got.content)  # a link in the folder to a file outside it
        (folder / "link_out.mcap").symlink_to(tmp_path / "elsewhere.mcap")
        for name in ("nothing.mcap", "notes.txt", "..%2F..%2Fetc%2Fpasswd", "%2Fetc%2Fpasswd", "link_out.mcap"):
            assert server.http.get(f"{server.url}/api/recordings/files/{name}", timeout=10).status_code == 404, name
    (entry,) = listing["files"]
    assert got.content == (folder / entry["name"]).read_bytes()
    assert entry["name"].endswith("_lab_test.mcap") and entry["size_bytes"] > 1000
    assert entry["duration_s"] > 0.5 and entry["messages"] == stopped["messages"]
    with LogReader(folder / entry["name"]) as log:
        assert log.indexed
        channels = {(c.robot_id, c.topic): c for c in log.channels}
        assert channels[("r1", "joint_states")].typename == "sensor_msgs/msg/JointState"
        assert ("r1", "robot_state") in channels
        seqs = [m.msg.position[0] for m in log.messages(topics=["joint_states"])]
        assert len(seqs) >= 40 and seqs == sorted(seqs)
        assert [b.name for b in log.bookmarks] == ["fell"]
        # images are not thinned for the recorder as they are for a browser: about 30 per 50 joint states
        assert channels[("r1", "camera/image/compressed")].message_count >= len(seqs) * 30 / 50 * 0.8


def test_kill_9_while_recording_keeps_the_file(router_endpoint: str, bus: BusConfig, tmp_path: Path) -> None:
    folder = tmp_path / "rec"
    node = TestStand("r1", bus, overrides={"rate_hz": 100.0}).start()
    try:
        with dashboard_server(["--connect", router_endpoint, "--no-telemetry", "--recordings", str(folder)],
                              tmp_path) as server:
            assert server.http.post(f"{server.url}/api/recordings/start", json={"name": "crash"}, timeout=10).is_success
            # 100 Hz joint_states and robot_state, and the /tf made of them (20 Hz): 340 hold 150 joint_states
            wait_for(lambda: (_status(server.url)["manual"] or {}).get("messages", 0) >= 340, timeout=30,
                     interval=0.2, what="340 messages recorded")
            node.shutdown()
            # once the stream is quiet the open chunk goes to disk: everything recorded is flushed
            status = wait_for(lambda: (s := _status(server.url)["manual"]) and s["messages"] > 0
                              and s["flushed_messages"] == s["messages"] and s, timeout=20, interval=0.2,
                              what="recording flushed")
            time.sleep(0.3)  # no message may be in flight between the status read and the kill
            status = _status(server.url)["manual"]
            os.kill(server.process.pid, signal.SIGKILL)
            server.process.wait(10)
    finally:
        node.shutdown()
    (path,) = folder.glob("*_crash.mcap")
    with LogReader(path) as log:
        assert not log.indexed  # no summary: the index was rebuilt from the chunks
        assert log.message_count == status["flushed_messages"] >= 300
        seqs = [m.msg.position[0] for m in log.messages(topics=["joint_states"])]
        assert seqs == sorted(seqs) and len(seqs) >= 150


class GameStand(Node):
    """Relays a GameController's state, as a robot's game_controller node does (the test sets ``state``)."""

    __test__ = False
    name = "game_controller"

    def setup(self) -> None:
        self.state = INITIAL
        self.pub = self.publisher("gamestate")
        self.timer(lambda: self.pub.publish(gamestate(self.state)), rate_hz=20.0)


def test_a_killed_server_goes_on_recording_after_its_restart(router_endpoint: str, bus: BusConfig,
                                                              tmp_path: Path) -> None:
    """SIGKILL while a manual and a match recording run: each file keeps what the server received until
    CRASH_LOSS_BOUND_S before the kill, and the restarted server goes on in the next file of each series."""
    folder = tmp_path / "rec"
    args = ["--connect", router_endpoint, "--no-telemetry", "--recordings", str(folder)]
    node = TestStand("r1", bus, overrides={"rate_hz": 100.0}).start()
    game = GameStand("r1", bus).start()
    try:
        with dashboard_server(args, tmp_path) as server:
            assert server.http.post(f"{server.url}/api/recordings/start", json={"name": "crash"}, timeout=10).is_success
            wait_for(lambda: (_status(server.url)["manual"] or {}).get("messages", 0) >= 100, timeout=30,
                     interval=0.1, what="recording, the game seen in INITIAL")
            game.state = READY
            wait_for(lambda: _status(server.url)["match"], timeout=30, interval=0.1, what="the match recorded")
            file = Path(_status(server.url)["manual"]["files"][0])
            size = file.stat().st_size
            wait_for(lambda: file.stat().st_size > size, timeout=30, what="a chunk written")
            time.sleep(1.5 * CRASH_LOSS_BOUND_S)  # the kill comes well after that chunk: only later ones keep the bound
            killed_at = time.time()
            os.kill(server.process.pid, signal.SIGKILL)
            server.process.wait(10)
        with dashboard_server(args, tmp_path) as server:
            status = wait_for(lambda: (s := _status(server.url))["match"] and s["manual"]
                              and min(s["match"]["messages"], s["manual"]["messages"]) >= 250 and s,
                              timeout=30, interval=0.1, what="both recordings going on")
            assert status["manual"]["resumed"] and status["match"]["resumed"]
            assert server.http.post(f"{server.url}/api/recordings/stop", timeout=20).is_success
        # the second server stopped cleanly: nothing is left to resume
        assert not (folder / JOURNAL_NAME).exists()
    finally:
        node.shutdown()
        game.shutdown()
    (manual,) = folder.glob("*_crash.mcap")
    (match,) = folder.glob("match-*_half1.mcap")
    for first in (manual, match):
        with LogSeriesReader(first) as log:
            assert [p.name for p in log.paths] == [first.name, f"{first.stem}_001.mcap"]
            recorded = [(m.log_time_ns / 1e9, m.msg.position[0]) for m in log.messages(topics=["joint_states"])]
        before = [t for t, _ in recorded if t < killed_at]
        after = [t for t, _ in recorded if t > killed_at]
        assert before[-1] >= killed_at - CRASH_LOSS_BOUND_S, (first.name, killed_at - before[-1])
        assert len(after) >= 50  # of the 250 messages waited for, most are joint_states (100 Hz against 20 Hz)
        seqs = [seq for _, seq in recorded]
        assert seqs == sorted(seqs)


def test_only_one_server_owns_a_folders_journal_and_old_journals_are_not_resumed(tmp_path: Path) -> None:
    async def main() -> None:
        hub = Hub()
        hub.bind(asyncio.get_running_loop())
        first, second = Recorder(hub, tmp_path), Recorder(hub, tmp_path)
        await first.start()
        await first.start_manual("lab")
        await second.start()  # e.g. `pitchside replay` beside a running dashboard: it takes nothing over
        assert second.manual is None and not second.journal.owned
        await second.close()
        assert (tmp_path / JOURNAL_NAME).exists()  # the first server's journal is untouched
        assert first.manual is not None
        first.journal.release()  # what the kernel does when the first server dies
        old = time.time() - RESUME_WITHIN_S - 60
        os.utime(tmp_path / JOURNAL_NAME, (old, old))  # ... and it died long ago
        late = Recorder(hub, tmp_path)
        await late.start()
        assert late.manual is None and not (tmp_path / JOURNAL_NAME).exists()
        await late.close()
        await first.manual.stop()

    asyncio.run(main())
    assert RecordingJournal(tmp_path).interrupted().manual is None


def test_recording_rotates_by_size_and_reads_back_as_one(tmp_path: Path) -> None:
    from schemas.logs import LogSeriesReader

    async def main() -> dict[str, Any]:
        hub = Hub()
        hub.bind(asyncio.get_running_loop())
        recorder = Recorder(hub, tmp_path, auto_match=False, rotate_bytes=300_000, chunk_size=32_000)
        await recorder.start()
        await recorder.start_manual("rotating")
        rng = np.random.default_rng(0)
        for k in range(2000):
            joints = schemas.make("sensor_msgs/msg/JointState", name=[f"j{i}" for i in range(20)],
                                  position=[float(k), *rng.normal(size=19).tolist()])  # barely compressible
            hub.publish(HubMessage("r1", "joint_states", joints.__msgtype__, time.time(), joints, "telemetry"))
            if k % 200 == 0:
                await asyncio.sleep(0.01)
        status = await recorder.stop_manual()
        await recorder.close()
        assert status is not None
        return status.as_dict()

    status = asyncio.run(main())
    assert len(status["files"]) >= 2 and status["dropped"] == 0
    for file in status["files"]:
        assert Path(file).stat().st_size < 300_000 + 20_000  # rotate_bytes plus at most a summary
    with LogSeriesReader(status["files"][0]) as log:
        seqs = [m.msg.position[0] for m in log.messages()]
    assert seqs == [float(k) for k in range(2000)] and status["messages"] == 2000
