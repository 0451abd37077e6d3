"""The robot's own log (robot_nodes.robot_log, a real process on the bus): a known set of messages recorded at full
rate, the process killed and restarted mid-half (a reboot: a new file), pulled over the bus by `pitchside logs pull`
and merged with a laptop log that holds every fifth message (telemetry) on a clock 3 s ahead: every message once,
on the laptop's clock; and the ring that drops the oldest halves first."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import zenoh

import schemas
from pitchside import logs
from robot_nodes.robot_log.ring import enforce
from robot_nodes.runtime import BusConfig
from schemas.logs import LogReader, LogWriter
from schemas.std import Header, JointState, Time
from server.recording.files import RecordingsFolder
from tests.support import REPO
from tests.waiting import wait_for
from wire import keys
from wire.bus import open_session

ROBOT = "r1"
LAPTOP_AHEAD_S = 3.0


@contextlib.contextmanager
def robot_log(router_endpoint: str, folder: Path, log_dir: Path, n: int = 0) -> Iterator[subprocess.Popen[bytes]]:
    with (log_dir / f"robot_log-{n}.log").open("wb") as out:
        process = subprocess.Popen([sys.executable, "-m", "robot_nodes.robot_log", "--robot-id", ROBOT, "--connect",
                                    router_endpoint, "--folder", str(folder)], cwd=REPO, stdout=out,
                                   stderr=subprocess.STDOUT, env=dict(os.environ, PYTHONUNBUFFERED="1"))
    try:
        yield process
    finally:
        if process.poll() is None:
            process.terminate()
            process.wait(10)


def joint_state(seq: int) -> bytes:
    stamp = Time(sec=seq // 100, nanosec=(seq % 100) * 10_000_000)
    empty = np.zeros(0)
    return schemas.encode(JointState(header=Header(stamp=stamp, frame_id=""), name=["a"],
                                     position=np.array([float(seq)]), velocity=empty, effort=empty))


def gamestate() -> bytes:
    return schemas.encode(schemas.make("humanoid_league_msgs/msg/GameState", game_state=3, first_half=True))


def logged_sequences(folder: Path) -> set[int]:
    seqs: set[int] = set()
    for path in folder.glob("*.mcap"):
        with contextlib.suppress(Exception), LogReader(path) as log:
            seqs |= {int(m.msg.position[0]) for m in log.messages(topics=["joint_states"])}
    return seqs


@pytest.mark.timeout(180)
def test_a_robots_log_survives_a_reboot_and_merges_with_the_laptops_log(router_endpoint: str, bus: BusConfig,
                                                                        tmp_path: Path) -> None:
    robot_folder, recordings = tmp_path / "robot", tmp_path / "recordings"
    recordings.mkdir()
    laptop_log = recordings / "match-test_half1.mcap"
    session = open_session(bus)
    joint_key, game_key = keys.topic_key(ROBOT, "joint_states"), keys.topic_key(ROBOT, "gamestate")
    published: list[int] = []
    laptop = LogWriter(laptop_log)

    def publish(seqs: range) -> None:
        for seq in seqs:
            data = joint_state(seq)
            session.put(joint_key, data, encoding=zenoh.Encoding("application/cdr"))
            published.append(seq)
            if seq % 5 == 0:  # what telemetry carried, on the laptop's clock
                laptop.write(ROBOT, "joint_states", data, log_time_ns=time.time_ns() + int(LAPTOP_AHEAD_S * 1e9))
            time.sleep(0.005)

    try:
        laptop.write(ROBOT, "overview_note", schemas.encode(schemas.std.String(data="laptop only")),
                     typename="std_msgs/msg/String")
        with robot_log(router_endpoint, robot_folder, tmp_path, 0) as first:
            wait_for(lambda: list(robot_folder.glob("*.mcap")) or (session.put(game_key, gamestate()) and False),
                     timeout=60, interval=0.2, what="the robot log's first file")
            publish(range(0, 200))
            wait_for(lambda: logged_sequences(robot_folder) >= set(range(0, 200)), timeout=30, interval=0.2,
                     what="the first 200 messages on the robot's disk")
            os.kill(first.pid, signal.SIGKILL)  # a reboot mid-half
            first.wait(10)
        with robot_log(router_endpoint, robot_folder, tmp_path, 1):
            wait_for(lambda: len(list(robot_folder.glob("*.mcap"))) >= 2
                     or (session.put(game_key, gamestate()) and False), timeout=60, interval=0.2,
                     what="the restarted robot log's file")
            publish(range(200, 400))
            wait_for(lambda: logged_sequences(robot_folder) >= set(range(200, 400)), timeout=30, interval=0.2,
                     what="the next 200 messages on the robot's disk")
            laptop.close()
            logs.main(["pull", "--robots", ROBOT, "--half", "half1", "--laptop-log", str(laptop_log),
                       "--connect", router_endpoint])
    finally:
        laptop.close()
        session.close()
    pulled = sorted((recordings / "robot_logs" / ROBOT).glob("*.mcap"))
    assert len(pulled) >= 2 and all(p.name.startswith(f"{ROBOT}_half1_") or "_pregame_" in p.name for p in pulled)
    record = json.loads(logs.pulled_record(laptop_log).read_text())
    info = record["robots"][ROBOT]
    assert info["clock_aligned"] and abs(info["clock_offset_s"] - LAPTOP_AHEAD_S) < 0.5, info
    assert info["duplicates_dropped"] == 80  # every fifth of 400: in both logs, written once
    with LogReader(logs.merged_path(laptop_log)) as merged:
        seqs = [int(m.msg.position[0]) for m in merged.messages(topics=["joint_states"])]
        times = [m.log_time_ns for m in merged.messages(topics=["joint_states"])]
        notes = list(merged.messages(topics=["overview_note"]))
    assert sorted(seqs) == published, "a message missing or doubled"
    assert seqs == sorted(seqs) and times == sorted(times)  # one timeline, on the laptop's clock
    assert len(notes) == 1  # what only the laptop had is kept
    # the dashboard's recordings list says which robots' logs are in the half
    (entry,) = [e for e in RecordingsFolder(recordings).listing(set()) if e["name"] == laptop_log.name]
    assert entry["pulled"] == [ROBOT]


def test_the_ring_drops_the_oldest_halves_first_and_never_the_file_being_written(tmp_path: Path) -> None:
    def file(name: str, size: int, age_s: float) -> Path:
        path = tmp_path / name
        path.write_bytes(b"\0" * size)
        os.utime(path, (time.time() - age_s, time.time() - age_s))
        return path

    old = [file("r1_half1_20260101-100000.mcap", 400, 300), file("r1_half1_20260101-100000_001.mcap", 400, 290)]
    middle = file("r1_half2_20260101-110000.mcap", 400, 200)
    writing = file("r1_half1_20260102-100000.mcap", 400, 0)
    dropped = enforce(tmp_path, cap_bytes=1000, keep_free_bytes=0, writing=writing)
    assert dropped == old  # the oldest half, both its files, and only as much as needed
    assert middle.exists() and writing.exists()
    assert enforce(tmp_path, cap_bytes=100, keep_free_bytes=0, writing=writing) == [middle]
    assert writing.exists()  # never the file being written, even over the cap


@pytest.mark.timeout(180)
def test_kill_9_of_every_writer_at_once_leaves_files_that_open_to_within_a_second(
        router_endpoint: str, bus: BusConfig, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The laptop's recorder and the robot's log, both SIGKILLed mid-write at the same moment: every file opens
    without repair and holds the messages until less than a second before the cut."""
    from server.recording.service import RECORDER_TOKEN_ENV
    from tests.running_recorder import answers, control, recorder_processes
    from tests.support import free_port
    from tests.teststand import TestStand

    token, port = "kill-all-token", free_port()
    monkeypatch.setenv(RECORDER_TOKEN_ENV, token)
    laptop, robot_folder = tmp_path / "recordings", tmp_path / "robot"
    node = TestStand(ROBOT, bus, overrides={"rate_hz": 100.0}).start()
    try:
        with recorder_processes(["--connect", router_endpoint, "--no-telemetry", "--recordings", str(laptop),
                                 "--control-port", str(port), "--no-auto-record"], tmp_path) as (recorder,), \
                robot_log(router_endpoint, robot_folder, tmp_path) as logger:
            wait_for(lambda: answers(port, token), timeout=60, interval=0.1, what="the recorder up")
            control(port, token, "/start", "POST")
            wait_for(lambda: control(port, token)["manual"]["messages"] > 300
                     and len(logged_sequences(robot_folder)) > 300, timeout=120, interval=0.5,
                     what="both writing")
            killed_at = time.time()
            for process in (recorder, logger):
                os.kill(process.pid, signal.SIGKILL)
            for process in (recorder, logger):
                process.wait(10)
    finally:
        node.shutdown()
    files = [*laptop.glob("*.mcap"), *robot_folder.glob("*.mcap")]
    assert len(files) >= 2
    for path in files:
        with LogReader(path) as log:  # opens as it is: the index rebuilt from its complete chunks
            last = max(m.log_time_ns for m in log.messages(topics=["joint_states"], decode=False)) / 1e9
        assert last >= killed_at - 1.0, (path.name, killed_at - last)


def test_the_lab_may_pull_a_robots_log_on_a_secured_bus_and_nobody_else_serves_it() -> None:
    """The robot log's keys lie in the robot's namespace of the domain: the team's access rules let the lab laptop
    ask for them and the robot answer, and a robot cannot answer for another robot's log."""
    from pitchside.team_access import Role, access_control
    from robot_nodes.robot_log.files import file_key, list_key

    rules = {rule["id"]: rule for rule in access_control({"laptop": Role.LAPTOP, "robot1": Role.ROBOT,
                                                          "robot2": Role.ROBOT, "router": Role.ROUTER})["rules"]}
    lab = [zenoh.KeyExpr(key) for key in rules["lab-requests"]["key_exprs"]]
    robot2 = [zenoh.KeyExpr(key) for key in rules["robot-robot2"]["key_exprs"]]
    for key in (zenoh.KeyExpr(list_key("robot1")), zenoh.KeyExpr(file_key("robot1"))):
        assert any(rule.includes(key) for rule in lab), key
        assert not any(rule.includes(key) for rule in robot2), key  # robot2 cannot serve robot1's log
    assert list_key("robot1").endswith("/robot1/_robot_log/list")
    with pytest.raises(ValueError, match="list or file"):
        keys.robot_log_key("robot1", "delete")
