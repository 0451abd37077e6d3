"""The README's "Several machines" and match setups on separate machines: Linux network namespaces (tests.netlab),
a team laptop at 10.88.0.1 and a robot at 10.88.0.2, joined by an emulated link."""

from __future__ import annotations

import json
import os
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.netlab import REPO, Machine, Network, network, skip_reason
from tests.waiting import wait_for

pytestmark = [pytest.mark.slow, pytest.mark.skipif(skip_reason() is not None, reason=skip_reason() or "")]
LAPTOP_ROUTER = "tcp/10.88.0.1:7447"
TOKEN = "machines-test-token"
DASHBOARD = "http://127.0.0.1:8080"


def api(machine: Machine, method: str, path: str, body: dict[str, Any] | None = None) -> dict[str, Any]:
    """A call to the dashboard from its own machine (where a browser would sit)."""
    argv = [sys.executable, "-m", "tests.netprobe", "http", method, DASHBOARD + path]
    done = machine.run(argv + ([json.dumps(body)] if body is not None else []), timeout=60, cwd=REPO,
                       env={**os.environ, "PITCHSIDE_TOKEN": TOKEN})
    assert done.returncode == 0, done.stderr
    return dict(json.loads(done.stdout.strip().splitlines()[-1]))


def robots(machine: Machine) -> dict[str, Any]:
    reply = api(machine, "GET", "/api/robots")
    return {r["robot"]: r for r in reply["body"]} if reply["status"] == 200 else {}


def watch(machine: Machine, out: Path, seconds: float, topics: list[str]) -> Any:
    """A browser-like WebSocket client on the machine, writing what it is shown into ``out``."""
    return machine.python(["tests.netprobe", "watch", DASHBOARD.replace("http", "ws") + "/ws", str(out),
                           "--seconds", str(seconds), *[a for t in topics for a in ("--topic", t)]],
                          out.with_suffix(".log"))


def shown(out: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in out.read_text().splitlines()] if out.exists() else []


@pytest.fixture
def net(tmp_path: Path) -> Iterator[Network]:
    with network(["laptop", "robot1"], tmp_path) as made:
        yield made


def test_the_readme_lab_commands_work_across_machines(net: Network, tmp_path: Path) -> None:
    """`pitchside router --listen tcp/0.0.0.0:7447` (laptop), `pitchside robot --robot-id robot1 --connect
    tcp/<laptop>:7447` (robot), `pitchside serve --connect tcp/<laptop>:7447` (laptop), as the README gives them."""
    laptop, robot = net["laptop"], net["robot1"]
    laptop.python(["pitchside.cli", "router", "--listen", "tcp/0.0.0.0:7447"], tmp_path / "router.log")
    robot.python(["pitchside.cli", "robot", "--robot-id", "robot1", "--connect", LAPTOP_ROUTER],
                 tmp_path / "robot.log", env={"MUJOCO_GL": "egl"})
    laptop.python(["pitchside.cli", "serve", "--connect", LAPTOP_ROUTER], tmp_path / "serve.log",
                  env={"PITCHSIDE_TOKEN": TOKEN})
    # the robot's nodes start one by one: the first streams heard may be others than these two
    heard = wait_for(lambda: (r := robots(laptop).get("robot1"))
                     and {"robot_state", "joint_states"} <= set(r["streams"]) and r, 120.0, 1.0,
                     "the dashboard hears robot1's robot_state and joint_states over the network")
    assert {"robot_state", "joint_states"} <= set(heard["streams"]), heard["streams"].keys()
    assert all(s["source"] == "live" for s in heard["streams"].values())
    # laptop -> robot: the control API reaches the robot's nodes (parameters of the HCM and the servo node)
    params = wait_for(lambda: (r := api(laptop, "GET", "/api/robots/robot1/params"))["status"] == 200
                      and {"hcm", "cm730"} <= set(r["body"]) and r, 60.0, 1.0, "the robot's parameters")
    assert params["body"]["hcm"]
    # the robot's nodes meet on the robot: one link leaves the robot, its router's to the laptop's
    links = robot.run(["ss", "-tnH", "state", "established", "dst", "10.88.0.1"]).stdout.strip().splitlines()
    assert len(links) == 1 and ":7447" in links[0], links


def test_in_a_match_the_laptop_sends_nothing_to_the_robot(net: Network, tmp_path: Path) -> None:
    """The documented match setup: the robot's bus stays on the robot, telemetry is its only traffic, and the
    laptop (dashboard in match mode, a browser attached) sends it no packet at all, ARP aside."""
    laptop, robot = net["laptop"], net["robot1"]
    key = tmp_path / "team.key"
    assert laptop.python(["pitchside.cli", "telemetry-key", str(key)], tmp_path / "key.log").wait(60) == 0
    laptop.python(["pitchside.cli", "serve", "--match", "--telemetry-key", str(key)], tmp_path / "serve.log",
                  env={"PITCHSIDE_TOKEN": TOKEN})
    # the documented order: the dashboard listens before the robots send (until then the laptop's kernel answers
    # each datagram with an ICMP port unreachable; the README says how to keep it quiet even then)
    wait_for(lambda: api(laptop, "GET", "/api/robots")["status"] == 200, 90.0, 1.0, "the match dashboard up")
    robot.python(["pitchside.cli", "robot", "--robot-id", "robot1", "--match", "--nodes", "hcm,pause,telemetry",
                  "--telemetry-to", "10.88.0.1", "--telemetry-key", str(key)], tmp_path / "robot.log")
    wait_for(lambda: "overview" in robots(laptop).get("robot1", {}).get("streams", {}), 90.0, 1.0,
             "robot1's telemetry at the dashboard")
    before = net.frames_between("laptop", "robot1")
    out = tmp_path / "shown.jsonl"
    browser = watch(laptop, out, 10.0, ["*"])
    assert browser.wait(60) == 0
    frames = shown(out)
    assert frames and {f["source"] for f in frames} == {"telemetry"}, frames[:3]
    assert net.frames_between("laptop", "robot1") == before == 0
    # the count would see a packet: one UDP datagram from the laptop to the robot is counted
    laptop.run([sys.executable, "-c", "import socket; socket.socket(socket.AF_INET, socket.SOCK_DGRAM)"
                ".sendto(b'x', ('10.88.0.2', 9))"])
    wait_for(lambda: net.frames_between("laptop", "robot1") == 1, 10.0, 0.1, "the probe datagram counted")


def cut_link(net: Network, laptop: Machine, out: Path, cut_s: float, call: bool) -> None:
    """Cuts robot1's link for cut_s (the experiment itself, not a wait), with a control call during a long cut,
    then waits for data to come back."""
    net.shape("robot1", cut=True)
    cut_at = time.time()
    if call:
        wait_for(lambda: robots(laptop)["robot1"]["status"] != "ok", 10.0, 0.1, "robot1 shown stale")
        reply = api(laptop, "GET", "/api/robots/robot1/params")  # a control call during the cut: refused at once
        assert reply["status"] == 503 and "silent" in reply["body"]["detail"], reply
    time.sleep(max(0.0, cut_at + cut_s - time.time()))
    net.shape("robot1", cut=False)
    restored = time.time()
    wait_for(lambda: any(f["arrival"] > restored for f in shown(out)), 10.0, 0.05, "data after the cut")
    wait_for(lambda: robots(laptop)["robot1"]["status"] == "ok", 10.0, 0.1, "robot1 ok again")


def test_after_a_link_cut_fresh_data_returns_and_old_data_is_never_shown_as_live(net: Network,
                                                                                    tmp_path: Path) -> None:
    laptop, robot = net["laptop"], net["robot1"]
    laptop.python(["pitchside.cli", "router", "--listen", "tcp/0.0.0.0:7447"], tmp_path / "router.log")
    robot.python(["pitchside.cli", "launch", "--robot-id", "robot1", "--connect", LAPTOP_ROUTER, "tests.teststand"],
                 tmp_path / "robot.log")
    laptop.python(["pitchside.cli", "serve", "--connect", LAPTOP_ROUTER, "--no-telemetry"], tmp_path / "serve.log",
                  env={"PITCHSIDE_TOKEN": TOKEN})
    wait_for(lambda: robots(laptop).get("robot1"), 90.0, 0.5, "robot1 heard")
    out = tmp_path / "shown.jsonl"
    browser = watch(laptop, out, 40.0, ["joint_states"])
    wait_for(lambda: len(shown(out)) > 50, 20.0, 0.2, "data before the cut")
    cut_link(net, laptop, out, 1.2, call=False)  # shorter than the link's lease: TCP delivers a burst of old data
    cut_link(net, laptop, out, 8.0, call=True)  # longer: the link is closed and opened again
    seen = len(shown(out))
    wait_for(lambda: len(shown(out)) > seen + 50, 20.0, 0.2, "data flowing again")
    browser.terminate()
    assert browser.wait(60) == 0
    ages = [f["arrival"] - f["stamp"] for f in shown(out)]
    assert max(ages) < 0.5, sorted(ages)[-5:]  # never old data shown as live
    late = robots(laptop)["robot1"]["streams"]["joint_states"].get("late", 0)
    assert late > 0  # what TCP delivered late after the short cut was held back (and recorded), not shown
