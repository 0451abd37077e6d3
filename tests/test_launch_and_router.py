"""Supervised node processes and a Zenoh router between machines (here: processes on loopback)."""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import threading
import time

import pytest

from robot_nodes.launch import Launcher, NodeProcess, node_command
from robot_nodes.runtime import BusConfig, ParameterClient, open_session
from tests.support import REPO, free_port
from tests.waiting import wait_for
from wire import keys


def test_a_killed_node_is_started_again_after_the_restart_delay_and_publishes(
        router_endpoint: str, caplog: pytest.LogCaptureFixture) -> None:
    """The launcher's decision, not a timing: a node killed is started again after ``restart_delay`` (no back-off for
    a first death) and its messages flow again. How long until they do, a Python process's start-up included, is
    bench/faults.py's figure (a loaded machine stretches it: 2.2 s once in a whole suite on 2 cores)."""
    talker = NodeProcess("talker", node_command("tests.proc_nodes", "robot1", [router_endpoint],
                                                extra=[]))
    talker.argv.insert(3, "talker")  # python -m tests.proc_nodes talker --robot-id ...
    launcher = Launcher([talker])
    thread = threading.Thread(target=launcher.run, daemon=True)
    thread.start()
    received: list[float] = []
    with caplog.at_level(logging.ERROR, logger="pitchside.launch"), \
            open_session(BusConfig(connect=[router_endpoint])) as session:
        session.declare_subscriber(keys.topic_key("robot1", "joint_states"),
                                   lambda sample: received.append(time.monotonic()))
        try:
            wait_for(lambda: received, timeout=20, what="talker publishing")
            first_pid = talker.pid
            assert first_pid is not None
            os.kill(first_pid, signal.SIGKILL)
            wait_for(lambda: talker.pid != first_pid, timeout=20, what="restarted process")
            restarted_at = talker.started_at
            wait_for(lambda: received[-1] > restarted_at, timeout=20, what="messages from the restarted node")
            assert talker.last_exit == "killed by SIGKILL"
            said = [r.getMessage() for r in caplog.records if "killed by SIGKILL" in r.getMessage()]
            assert len(said) == 1 and said[0].endswith(f"restarting in {launcher.restart_delay:.1f} s"), said
        finally:
            launcher.stop()
            thread.join(15)
    assert talker.process is not None and talker.process.poll() is not None, "launcher must stop its nodes"


def test_a_node_in_back_off_does_not_hold_up_the_restart_of_another(router_endpoint: str,
                                                                    caplog: pytest.LogCaptureFixture) -> None:
    broken = NodeProcess("broken", [sys.executable, "-m", "tests.proc_nodes"])  # no node name: exits at once
    broken.restarts = 8  # it has been dying for a while: its next start is max_delay away
    once = NodeProcess("once", [sys.executable, "-c", "pass"], restart=False)
    talker = NodeProcess("talker", [sys.executable, "-m", "tests.proc_nodes", "talker", "--robot-id", "robot1",
                                    "--connect", router_endpoint])
    launcher = Launcher([broken, once, talker], max_delay=60.0)
    thread = threading.Thread(target=launcher.run, daemon=True)
    received: list[float] = []
    with caplog.at_level(logging.WARNING, logger="pitchside.launch"), \
            open_session(BusConfig(connect=[router_endpoint])) as session:
        session.declare_subscriber(keys.topic_key("robot1", "joint_states"),
                                   lambda sample: received.append(time.monotonic()))
        thread.start()
        try:
            wait_for(lambda: received and broken.restart_at is not None, timeout=20, what="talker up, broken waiting")
            broken_pid, first_pid = broken.pid, talker.pid
            assert first_pid is not None
            os.kill(first_pid, signal.SIGKILL)
            killed_at = time.monotonic()
            wait_for(lambda: talker.pid != first_pid and received[-1] > killed_at + 0.05, timeout=20,
                     what="the talker back while the broken node still waits")
            assert broken.pid == broken_pid and broken.restart_at is not None
        finally:
            launcher.stop()
            thread.join(15)
    assert [r.getMessage() for r in caplog.records if r.getMessage().startswith("once")] == [
        "once exited with code 0; not restarting"]  # said once, not on every look


def test_launch_process_stops_all_nodes_on_sigint(router_endpoint: str) -> None:
    proc = subprocess.Popen([sys.executable, "-m", "robot_nodes.launch", "tests.proc_nodes",
                             "--connect", router_endpoint], cwd=REPO, stderr=subprocess.PIPE, text=True)
    # "tests.proc_nodes" without a node name exits at once: the launcher restarts it with back-off and logs why
    assert proc.stderr is not None
    lines: list[str] = []
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline and not any("restarting" in line for line in lines):
        lines.append(proc.stderr.readline())
    assert any("exited with code" in line and "restarting" in line for line in lines), lines
    proc.send_signal(signal.SIGINT)
    assert proc.wait(15) == 0


def test_two_clients_meet_only_through_a_pitchside_router() -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = subprocess.Popen([sys.executable, "-m", "pitchside.cli", "router", "--listen", endpoint], cwd=REPO)
    talker = subprocess.Popen([sys.executable, "-m", "tests.proc_nodes", "talker", "--connect", endpoint,
                               "--mode", "client", "--robot-id", "far"], cwd=REPO)
    try:
        with open_session(BusConfig(connect=[endpoint], mode="client")) as session:
            frames: list[str] = []
            session.declare_subscriber(keys.topic_key("far", "joint_states"), lambda s: frames.append("x"))
            wait_for(lambda: len(frames) > 20, timeout=20, what="messages relayed by the router")
            client = ParameterClient(session, "far", timeout=10)
            client.set("talker", {"label": "tuned"})
            assert client.get("talker", "label") == "tuned"
    finally:
        talker.terminate()
        talker.wait(10)
        router.terminate()
        assert router.wait(10) == 0
