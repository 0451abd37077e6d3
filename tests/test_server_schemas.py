"""What the server tells the page about messages: the .msg files' constants, the topic table, the numeric fields of
a stream; and that the page keeps no copy of its own. Real server, messages fed in through replay of a real log."""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

import schemas
from schemas.codec import OWN_PACKAGES, SCHEMA_DIR
from schemas.logs import LogWriter
from tests.dashboard_server import RunningServer, dashboard_server
from tests.support import REPO
from tests.waiting import wait_for

WEB = REPO / "web"
T0 = 1_700_000_000_000_000_000  # ns
CONSTANT = re.compile(r"^\s*(\w+)\s+([A-Z][A-Z0-9_]*)\s*=\s*(\S+)", re.MULTILINE)
LITERAL = re.compile(r"""["'`]([A-Z][A-Z0-9_]+)["'`]""")
# words of HTTP, the DOM and the page's own labels, not message constants
NOT_MESSAGE_WORDS = {"GET", "POST", "PUT", "DELETE", "INPUT", "LOST", "PENALIZED", "HCM",
                     "STOPPED", "REPLAY"}  # words shown: GameState.stopped, a replayed robot


def msg_file_constants() -> dict[str, dict[str, int]]:
    """The constants our .msg files declare, read from their text (not through the typestore)."""
    found = {}
    for package in OWN_PACKAGES:
        for path in sorted((SCHEMA_DIR / package / "msg").glob("*.msg")):
            consts = {name: int(value) for _, name, value in CONSTANT.findall(path.read_text())}
            if consts:
                found[f"{package}/msg/{path.stem}"] = consts
    return found


def web_sources() -> dict[Path, str]:
    return {path: path.read_text() for path in sorted(WEB.rglob("*.js"))}


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The server's recordings folder: replay opens logs from here."""
    return tmp_path_factory.mktemp("schemas")


@pytest.fixture(scope="module")
def server(folder: Path) -> Iterator[RunningServer]:
    with dashboard_server(["--no-live", "--no-telemetry", "--recordings", str(folder)], folder) as running:
        yield running


def test_the_server_serves_the_msg_files_constants(server: RunningServer) -> None:
    served = server.http.get(f"{server.url}/api/schemas").json()
    files = msg_file_constants()
    carried = set(served["constants"])
    for typename, consts in files.items():
        if typename in carried:
            assert served["constants"][typename] == consts, typename
    for typename in ("humanoid_league_msgs/msg/RobotControlState", "humanoid_league_msgs/msg/GameState",
                     "humanoid_league_msgs/msg/ObstacleRelative", "pitchside_msgs/msg/RobotOverview",
                     "pitchside_msgs/msg/ServoHealth"):
        assert served["constants"][typename] == files[typename]
    # standard types nested in the topics' messages come from the same typestore
    assert served["constants"]["diagnostic_msgs/msg/DiagnosticStatus"] == {"OK": 0, "WARN": 1, "ERROR": 2, "STALE": 3}
    assert served["constants"]["humanoid_league_msgs/msg/RobotControlState"]["HARDWARE_PROBLEM"] == 13


def test_the_server_serves_the_topic_table(server: RunningServer) -> None:
    served = server.http.get(f"{server.url}/api/schemas").json()["topics"]
    assert set(served) == set(schemas.TOPICS)
    for name, topic in schemas.TOPICS.items():
        assert served[name] == {"type": topic.type, "description": topic.description,
                                "priority": topic.priority.name, "event": topic.event}
    events = {name for name, t in served.items() if t["event"]}
    assert {"speak", "animation", "cmd_vel", "motor_goals", "team_data"} <= events
    assert not events & {"robot_state", "joint_states", "overview", "servo_health", "strategy"}
    assert served["overview"]["type"] == "pitchside_msgs/msg/RobotOverview"
    assert served["servo_health"]["type"] == "pitchside_msgs/msg/ServoHealth"


def test_the_page_keeps_no_copy_of_constants_or_event_topics() -> None:
    files = msg_file_constants() | {"diagnostic_msgs/msg/DiagnosticStatus":
                                    schemas.constants("diagnostic_msgs/msg/DiagnosticStatus")}
    names = {name for consts in files.values() for name in consts}
    prefixes = {name[:i + 1] for name in names for i, c in enumerate(name) if c == "_"}
    events = {t.name for t in schemas.TOPICS.values() if t.event}
    for path, text in web_sources().items():
        literals = set(LITERAL.findall(text))
        # a constant the page names (a state it treats specially) is one the .msg files declare
        unknown = literals - names - prefixes - NOT_MESSAGE_WORDS
        assert not unknown, f"{path.name} names {sorted(unknown)}, which no .msg declares"
        # no table of a message's constants: never all of one type's names in one file
        for typename, consts in files.items():
            if len(consts) >= 3:
                assert not set(consts) <= literals, f"{path.name} copies the constants of {typename}"
        # no list of the event topics: the topic table says which they are
        copied = {t for t in events if re.search(rf"""["'`]{re.escape(t)}["'`]""", text)}
        assert len(copied) <= 2, f"{path.name} lists event topics {sorted(copied)}"
    assert "EVENT_TOPICS" not in web_sources()[WEB / "store.js"]


def _log_of_joint_states(path: Path) -> None:
    with LogWriter(path) as writer:
        for k in range(20):
            msg = schemas.make("sensor_msgs/msg/JointState", name=["HeadPan", "LKnee"], position=[0.1 * k, -0.2],
                               velocity=[], effort=[])
            writer.write("r1", "joint_states", msg, log_time_ns=T0 + k * 10_000_000)
            state = schemas.make("humanoid_league_msgs/msg/RobotControlState", state=10)
            writer.write("r1", "robot_state", state, log_time_ns=T0 + k * 10_000_000 + 1)


def test_numeric_fields_of_a_stream(server: RunningServer, folder: Path) -> None:
    _log_of_joint_states(folder / "joints.mcap")
    http = server.http
    assert http.get(f"{server.url}/api/fields/r1/joint_states").status_code == 404  # nothing arrived yet
    assert http.post(f"{server.url}/api/replay/open", json={"path": "joints.mcap"}).status_code == 200
    assert http.post(f"{server.url}/api/replay/step", json={"count": 40}).status_code == 200

    def fields(robot: str, topic: str) -> Any:
        reply = http.get(f"{server.url}/api/fields/{robot}/{topic}")
        return reply.json() if reply.status_code == 200 else None

    robot = "replay.r1"  # the log's r1, kept apart from a live r1
    joints = wait_for(lambda: fields(robot, "joint_states"), 10.0, 0.1, "fields of joint_states")
    assert joints["msgtype"] == "sensor_msgs/msg/JointState"
    assert joints["fields"] == [  # no header, no empty arrays
        {"path": "position/0", "label": "position/0 (HeadPan)", "name": "position/HeadPan"},
        {"path": "position/1", "label": "position/1 (LKnee)", "name": "position/LKnee"}]
    assert fields(robot, "robot_state")["fields"] == [{"path": "state", "label": "state", "name": "state"}]
    assert http.get(f"{server.url}/api/fields/r1/no/such/topic").status_code == 404
    http.post(f"{server.url}/api/replay/close")


def test_numeric_paths_address_the_json_view() -> None:
    """Every path the server offers finds its number in the message's JSON view (what the panels read)."""
    msgs = [schemas.make("sensor_msgs/msg/JointState", name=["a", "b", "c"], position=[1.0, 2.0, 3.0]),
            schemas.make("sensor_msgs/msg/Imu", angular_velocity=schemas.make("geometry_msgs/msg/Vector3", y=-2.5)),
            schemas.make("humanoid_league_msgs/msg/ObstaclesRelative", obstacles=[
                schemas.make("humanoid_league_msgs/msg/ObstacleRelative", color=2, width=0.3)]),
            schemas.make("pitchside_msgs/msg/RobotOverview", pose_x=1.5, battery_voltage=math.nan)]
    from schemas.numeric import numeric_values

    for msg in msgs:
        data = schemas.to_dict(msg)
        for field in numeric_values(msg):
            value = data
            for key in field.path.split("/"):
                value = value[int(key)] if isinstance(value, list) else value[key]
            assert value == field.value or (value is None and math.isnan(field.value)), (msg.__msgtype__, field)
