"""Actions on ROS 2's action protocol over rmw_zenoh, against peers written from the protocol description
(tests/ros2_action_peer.py): a ROS 2 client drives pitchside's animation node, and pitchside's client (and the
dashboard) drive a ROS 2 robot's PlayAnimation server. Real Zenoh sessions through a real router on loopback.
"""

from __future__ import annotations

import contextlib
import json
import threading
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import zenoh
from hypothesis import given, settings
from hypothesis import strategies as st
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

import schemas
from pitchside.team_access import Role, access_control
from pitchside.team_keys import create_team
from robot_nodes.animation.node import AnimationNode
from robot_nodes.runtime import Node
from schemas.codec import SchemaError
from schemas.interface_folder import load_interfaces
from schemas.type_hash import type_hash
from tests.dashboard_server import dashboard_server
from tests.ros2_action_peer import (
    ABORTED,
    CANCEL_GOAL_HASH,
    CANCELED,
    EXECUTING,
    GOAL_STATUS_ARRAY_HASH,
    SUCCEEDED,
    UNKNOWN,
    PeerActionClient,
    PeerActionServer,
)
from tests.support import REPO, free_port
from tests.test_bus_security import linked_to_team_router, member_session, robot_process, robot_router
from tests.waiting import wait_for
from wire.actions import ActionClient, GoalStatus
from wire.bus import BusConfig, open_router, open_session
from wire.ros2.actions import Part, action_interface, decode_cancel

pytestmark = pytest.mark.realtime
NOD = {"name": "nod", "keyframes": [{"duration": 0.3, "goals": {"HeadTilt": -20.0}},
                                    {"duration": 0.3, "goals": {"HeadTilt": 0.0}}]}
SLOW = {"name": "slow_look", "keyframes": [{"duration": 4.0, "goals": {"HeadPan": 60.0}}]}
GOAL = "humanoid_league_msgs/action/PlayAnimation_Goal"


# what ROS 2 Jazzy publishes for the keys of the action tutorial's /fibonacci (action_tutorials_interfaces'
# Fibonacci.action: int32 order --- int32[] sequence --- int32[] partial_sequence), as rmw_zenoh's keys carry them
FIBONACCI = {
    "Fibonacci_SendGoal": "RIHS01_a0603060ed69fe2dfbd1a6f3b982a1749957ef346e4a4d2b311a05e305ec37bb",
    "Fibonacci_GetResult": "RIHS01_8b47e383f1e31f6d8df6417ab54957e7d5ea24dad315646ad711ac3fdea81d58",
    "Fibonacci_FeedbackMessage": "RIHS01_50fc26b9cac313652ecbeab3adf9b5414d59fd4d4d5f9058ddcc7525169927f1",
}


def test_action_keys_carry_the_types_and_hashes_ros2_publishes(tmp_path: Path) -> None:
    interface = action_interface("humanoid_league_msgs/action/PlayAnimation")
    keys = {part: interface.key(0, "/robot1/animation", part).keyexpr for part in Part}
    assert keys[Part.STATUS] == ("0/robot1/animation/_action/status/action_msgs::msg::dds_::GoalStatusArray_/"
                                 + GOAL_STATUS_ARRAY_HASH)
    assert keys[Part.CANCEL_GOAL] == ("0/robot1/animation/_action/cancel_goal/action_msgs::srv::dds_::CancelGoal_/"
                                      + CANCEL_GOAL_HASH)
    # a service's type is its name without _Request/_Response, as rmw_zenoh writes it
    assert keys[Part.SEND_GOAL].startswith("0/robot1/animation/_action/send_goal/"
                                           "humanoid_league_msgs::action::dds_::PlayAnimation_SendGoal_/RIHS01_")
    folder = tmp_path / "action_tutorials_interfaces" / "action"
    folder.mkdir(parents=True)
    (folder / "Fibonacci.action").write_text("int32 order\n---\nint32[] sequence\n---\nint32[] partial_sequence\n")
    defs = {**get_typestore(Stores.ROS2_JAZZY).fielddefs, **load_interfaces(tmp_path)}
    for name, published in FIBONACCI.items():
        assert type_hash(f"action_tutorials_interfaces/action/{name}", defs) == published, name


class JointStates(Node):
    """Stands where cm730 would: the animation node starts from the robot's pose."""

    name = "body"

    def setup(self) -> None:
        self.joint_states = self.publisher("joint_states")
        self.timer(lambda: self.joint_states.publish(schemas.make(
            "sensor_msgs/msg/JointState", name=["HeadPan", "HeadTilt"], position=[0.0, 0.0])), rate_hz=50.0)


@pytest.fixture
def player(bus: BusConfig, tmp_path: Path) -> Iterator[AnimationNode]:
    (tmp_path / "nod.json").write_text(json.dumps(NOD))
    (tmp_path / "slow_look.json").write_text(json.dumps(SLOW))
    body = JointStates(bus=bus).start()
    node = AnimationNode(bus=bus, overrides={"animation_dir": str(tmp_path)}).start()
    wait_for(lambda: node.joint_positions is not None, 10.0, what="joint_states at the animation node")
    yield node
    node.shutdown()
    body.shutdown()


@pytest.fixture
def peer_session(bus: BusConfig) -> Iterator[zenoh.Session]:
    session = open_session(bus)
    yield session
    session.close()


def test_a_ros2_client_plays_cancels_and_is_told_no_by_pitchsides_animation_server(
        player: AnimationNode, peer_session: zenoh.Session) -> None:
    tokens: list[str] = []
    peer_session.liveliness().declare_subscriber("@ros2_lv/0/**", lambda s: tokens.append(str(s.key_expr)),
                                                 history=True)
    client = PeerActionClient(peer_session, 0, "/robot1/animation")
    try:
        # what `ros2 action list` reads: the node's services and topics of /robot1/animation, with their QoS
        wait_for(lambda: any("/SS/%/%robot1/animation/%robot1%animation%_action%send_goal/" in t for t in tokens),
                 what="the send_goal server's token")
        status_token = (f"/MP/%/%robot1/animation/%robot1%animation%_action%status/"
                        f"action_msgs::msg::dds_::GoalStatusArray_/{client.keys['status'].rsplit('/', 1)[1]}"
                        f"/:1:,1:,:,:,,")
        # the node's tokens arrive one by one (its parameter services too): the status publisher's among them
        wait_for(lambda: any(t.endswith(status_token) for t in list(tokens)),
                 what=lambda: f"{status_token} in {tokens}")

        played = uuid.uuid4().bytes
        accepted, stamp_ns = client.send_goal(played, "nod")
        assert accepted and stamp_ns > 0
        status, result = client.get_result(played)  # answered when the animation ends
        assert (status, bool(result.successful)) == (SUCCEEDED, True)
        percents = [percent for goal_id, percent in client.feedback if goal_id == played]
        assert percents and percents == sorted(percents) and percents[-1] == pytest.approx(100.0)
        wait_for(lambda: any(s.get(played) == SUCCEEDED for s in client.statuses), what="SUCCEEDED on status")
        assert any(s.get(played) == EXECUTING for s in client.statuses)
        assert client.get_result(played) == (SUCCEEDED, result)  # kept for a late asker

        long = uuid.uuid4().bytes
        assert client.send_goal(long, "slow_look")[0]
        assert client.cancel(long) == (0, [long])  # ERROR_NONE, the goal canceling
        status, result = client.get_result(long)
        assert status == CANCELED and not result.successful
        assert client.cancel(long) == (3, [])  # ERROR_GOAL_TERMINATED
        stranger = uuid.uuid4().bytes
        assert client.cancel(stranger) == (2, [])  # ERROR_UNKNOWN_GOAL_ID
        assert client.get_result(stranger)[0] == UNKNOWN
        assert client.cancel(bytes(16)) == (1, [])  # "cancel all" with nothing running: ERROR_REJECTED

        first, second = uuid.uuid4().bytes, uuid.uuid4().bytes  # a newer goal preempts: the older ends ABORTED
        assert client.send_goal(first, "slow_look")[0] and client.send_goal(second, "nod")[0]
        assert client.get_result(first)[0] == ABORTED
        assert client.get_result(second)[0] == SUCCEEDED

        refused = uuid.uuid4().bytes
        assert client.send_goal(refused, "moonwalk") == (False, 0)
        status, result = client.get_result(refused)  # pitchside's addition: why, for a client that asks
        assert status == UNKNOWN and "moonwalk" in result.message
        assert client.samples_without_attachment == 0
        assert player.server.unknown_goals == 2  # a cancel and a get_result named no goal the server knows
    finally:
        client.close()


def test_bad_requests_are_answered_or_dropped_and_counted(player: AnimationNode, peer_session: zenoh.Session
                                                          ) -> None:
    client = PeerActionClient(peer_session, 0, "/robot1/animation")
    try:
        wait_for(lambda: client.call("get_result", b"\x00\x01\x00\x00" + bytes(16), 1.0) is not None,
                 what="the action server")
        server = player.server
        bad = client.call("send_goal", b"\x00\x01\x00\x00" + uuid.uuid4().bytes + b"\xff\xff")  # goal cut short
        assert bad is not None and bad[4] == 0  # accepted: false
        assert client.call("cancel_goal", b"\x00\x01") is not None  # answered ERROR_REJECTED
        assert client.call("get_result", b"junk") is not None  # answered STATUS_UNKNOWN
        assert server.bad_requests == 3
        assert player._diag_values["animation/bad_requests"] == "3"  # in the node's diagnostics
        assert client.call("send_goal", b"", timeout_s=0.5, with_attachment=False) is None  # rmw_zenoh drops it
        wait_for(lambda: server.dropped == 1, what="the request without attachment counted")
        played = uuid.uuid4().bytes
        assert client.send_goal(played, "nod")[0]  # the server goes on
        assert client.get_result(played)[0] == SUCCEEDED
        assert player.errors == 0
    finally:
        client.close()


@pytest.fixture
def ros2_robot(peer_session: zenoh.Session) -> Iterator[PeerActionServer]:
    server = PeerActionServer(peer_session, 0, "/robot7", "animation_server", "/robot7/animation")
    yield server
    server.close()


def test_pitchsides_client_runs_a_ros2_robots_animation_server(ros2_robot: PeerActionServer, bus: BusConfig
                                                               ) -> None:
    with open_session(bus) as session:
        client = ActionClient(session, "robot7", "animation")
        try:
            feedback: list[float] = []
            goal = client.send_goal(schemas.make(GOAL, animation="wave"),
                                    on_feedback=lambda f: feedback.append(f.percent_done))
            assert goal.wait_accepted(10.0), goal.reason
            (goal_id,) = ros2_robot.goals
            assert goal_id == goal.id and ros2_robot.goals[goal_id]["animation"] == "wave"
            wait_for(lambda: goal.live_status == GoalStatus.EXECUTING, what="EXECUTING from the status topic")
            for percent in (25.0, 50.0):
                ros2_robot.feedback(goal_id, percent)
            wait_for(lambda: feedback == [25.0, 50.0], what="the robot's feedback")
            ros2_robot.finish(goal_id, SUCCEEDED, successful=True, message="waved")
            status, result = goal.wait_result(10.0)
            assert status == GoalStatus.SUCCEEDED and result.successful and result.message == "waved"

            refused = client.send_goal(schemas.make(GOAL, animation="refuse"))
            assert refused.wait_accepted(10.0) is False
            assert refused.reason == "rejected by /robot7/animation"  # a ROS 2 server gives no reason

            long = client.send_goal(schemas.make(GOAL, animation="long"))
            assert long.wait_accepted(10.0)
            assert long.cancel(10.0)
            assert long.wait_result(10.0)[0] == GoalStatus.CANCELED
            assert ros2_robot.cancel_requests == 1 and client.bad_replies == 0
        finally:
            client.close()


def test_the_dashboard_plays_an_animation_on_a_ros2_robot(ros2_robot: PeerActionServer, router_endpoint: str,
                                                          tmp_path: Path) -> None:
    with dashboard_server(["--connect", router_endpoint, "--no-telemetry"], tmp_path) as server:
        url = f"{server.url}/api/robots/robot7/animation-play"

        def finish_when_asked() -> bool:
            for goal_id, goal in list(ros2_robot.goals.items()):
                if goal["waiting"]:
                    ros2_robot.finish(goal_id, SUCCEEDED, successful=True, message="done")
                    return True
            return False

        answer: list[Any] = []
        request = threading.Thread(target=lambda: answer.append(
            server.http.post(url, json={"animation": "stand", "wait": True}, timeout=30)))
        request.start()
        wait_for(finish_when_asked, 20.0, what="the dashboard's goal waiting for its result")
        request.join(30)
        reply = answer[0]
        assert reply.status_code == 200, reply.text
        assert reply.json()["status"] == "SUCCEEDED" and reply.json()["result"]["successful"] is True
        refused = server.http.post(url, json={"animation": "refuse"}, timeout=30)
        assert refused.status_code == 409 and "rejected by /robot7/animation" in refused.json()["detail"]


def test_the_guides_python_example_plays_on_a_ros2_robot(ros2_robot: PeerActionServer, bus: BusConfig,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    """docs/guides/ros2-actions.md's snippet, run as written; the robot reports 40 % and ends the goal when asked."""
    text = (REPO / "docs" / "guides" / "ros2-actions.md").read_text()
    snippet = text.split("```python", 1)[1].split("\n", 1)[1].split("```", 1)[0]  # the fence has a title

    def play_when_asked() -> bool:
        for goal_id, goal in list(ros2_robot.goals.items()):
            if goal["waiting"]:
                ros2_robot.feedback(goal_id, 40.0)
                ros2_robot.finish(goal_id, SUCCEEDED, successful=True, message="")
                return True
        return False

    with open_session(bus) as session:
        robot = threading.Thread(target=lambda: wait_for(play_when_asked, 20.0, what="the snippet's goal"))
        robot.start()
        exec(compile(snippet, "docs/guides/ros2-actions.md", "exec"), {"session": session})
        robot.join(30)
    out = capsys.readouterr().out.splitlines()
    assert out[-1] == "SUCCEEDED True"
    assert out[:-1] in ([], ["40 %"])  # the feedback and the result travel apart: the result may come first


def test_the_lab_may_ask_a_robots_action_services_on_a_secured_bus() -> None:
    """The team's access rules (pitchside/team_access.py): the lab laptop may query send_goal, cancel_goal and
    get_result of any robot's action (it may query the whole domain: a query on a topic's key reaches no
    queryable but a latched topic's cache); feedback and status are put only by the robot."""
    rules = {rule["id"]: rule for rule in access_control({"laptop": Role.LAPTOP, "robot1": Role.ROBOT,
                                                          "router": Role.ROUTER})["rules"]}
    lab = [zenoh.KeyExpr(key) for key in rules["lab-requests"]["key_exprs"]]
    lab_puts = [zenoh.KeyExpr(key) for key in rules["lab-commands"]["key_exprs"]]
    robot = [zenoh.KeyExpr(key) for key in rules["robot-robot1"]["key_exprs"]]
    interface = action_interface("humanoid_league_msgs/action/PlayAnimation")
    for part in Part:
        key = zenoh.KeyExpr(interface.key(0, "/robot1/animation", part).keyexpr)
        if part in (Part.SEND_GOAL, Part.CANCEL_GOAL, Part.GET_RESULT):
            assert any(rule.includes(key) for rule in lab), part
        assert not any(rule.includes(key) for rule in lab_puts), part  # the lab never puts an action's topics
        assert any(rule.includes(key) for rule in robot), part  # its replies, feedback and status


@settings(max_examples=300, deadline=None, database=None)
@given(st.binary(max_size=96))
def test_the_protocols_messages_from_the_network_decode_or_fail_with_one_error(data: bytes) -> None:
    """What a server or client decodes from the bus: any bytes give a message or SchemaError, nothing else."""
    interface = action_interface("humanoid_league_msgs/action/PlayAnimation")
    for envelope in ("SendGoal_Request", "SendGoal_Response", "GetResult_Request", "GetResult_Response",
                     "FeedbackMessage"):
        with contextlib.suppress(SchemaError):
            interface.decode(envelope, data)
    for envelope in ("Request", "Response"):
        with contextlib.suppress(SchemaError):
            decode_cancel(envelope, data)
    with contextlib.suppress(SchemaError):
        schemas.decode(data, "action_msgs/msg/GoalStatusArray")


def test_a_kick_goal_is_the_cdr_a_ros2_client_sends() -> None:
    """Kick's goal has a Header and float64 points after the 16-byte goal id: pitchside's SendGoal_Request is byte
    for byte what rosbags makes of the same structure defined from Kick.action, and decodes back."""
    store = get_typestore(Stores.ROS2_JAZZY)
    for name, text in {
        "peer_msgs/msg/KickGoal": "std_msgs/Header header\ngeometry_msgs/Point ball_position\n"
                                  "geometry_msgs/Quaternion kick_direction\nfloat32 kick_speed\nbool unstable\n",
        "peer_msgs/msg/KickSendGoal": "unique_identifier_msgs/UUID goal_id\npeer_msgs/KickGoal goal\n",
    }.items():
        store.register(get_types_from_msg(text, name))
    t = store.types
    goal_id = bytes(range(16))
    theirs = t["peer_msgs/msg/KickSendGoal"](
        goal_id=t["unique_identifier_msgs/msg/UUID"](uuid=np.frombuffer(goal_id, dtype=np.uint8).copy()),
        goal=t["peer_msgs/msg/KickGoal"](
            header=t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=3, nanosec=7), frame_id="b"),
            ball_position=t["geometry_msgs/msg/Point"](x=0.25, y=-0.5, z=0.0),
            kick_direction=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.5, w=0.75),
            kick_speed=1.5, unstable=True))
    interface = action_interface("humanoid_league_msgs/action/Kick")
    goal = schemas.make(interface.goal_type, header=schemas.make(
        "std_msgs/msg/Header", stamp=schemas.make("builtin_interfaces/msg/Time", sec=3, nanosec=7), frame_id="b"),
        ball_position=schemas.make("geometry_msgs/msg/Point", x=0.25, y=-0.5, z=0.0),
        kick_direction=schemas.make("geometry_msgs/msg/Quaternion", x=0.0, y=0.0, z=0.5, w=0.75),
        kick_speed=1.5, unstable=True)
    ours = interface.send_goal_request(goal_id, goal)
    assert ours == bytes(store.serialize_cdr(theirs, "peer_msgs/msg/KickSendGoal"))
    decoded = interface.decode("SendGoal_Request", ours)
    assert bytes(decoded.goal_id.uuid) == goal_id and decoded.goal.kick_direction.w == 0.75
    assert interface.key(0, "/robot1/kick", Part.SEND_GOAL).keyexpr.startswith(
        "0/robot1/kick/_action/send_goal/humanoid_league_msgs::action::dds_::Kick_SendGoal_/RIHS01_")


def test_on_the_secured_bus_the_lab_laptop_plays_and_a_viewer_cannot(tmp_path: Path) -> None:
    """The team's files (pitchside team-keys): the team router with mutual TLS and access control, robot1's own
    router, the animation node a plain peer of it; the laptop's goal plays, the viewer's never reaches the node."""
    folder = tmp_path / "team"
    create_team(folder, "Test Team", ["robot1"], ["laptop"], ["viewer"], router_port=free_port())
    (tmp_path / "anim").mkdir()
    (tmp_path / "anim" / "nod.json").write_text(json.dumps(NOD))
    team_router = open_router(config_file=folder / "router.json5")
    robot = robot_router(folder, "robot1")
    sessions: list[zenoh.Session] = []
    nodes: list[Node] = []
    try:
        wait_for(lambda: linked_to_team_router(robot, team_router), 10.0, what="robot1's router at the team's")
        on_robot = robot_process(robot)
        sessions.append(on_robot)
        nodes += [JointStates(bus=on_robot).start(),
                  AnimationNode(bus=on_robot, overrides={"animation_dir": str(tmp_path / "anim")}).start()]
        laptop, viewer = member_session(folder, "laptop"), member_session(folder, "viewer")
        sessions += [laptop, viewer]
        lab = ActionClient(laptop, "robot1", "animation")
        goal = lab.send_goal(schemas.make(GOAL, animation="nod"), timeout=10.0)
        assert goal.wait_accepted(10.0), goal.reason
        assert goal.wait_result(10.0)[0] == GoalStatus.SUCCEEDED
        stranger = ActionClient(viewer, "robot1", "animation")
        refused = stranger.send_goal(schemas.make(GOAL, animation="nod"), timeout=1.0)
        assert refused.wait_accepted(5.0) is False and "no action server /robot1/animation answered" in refused.reason
        assert len(nodes[1].server.goals) == 1  # the laptop's only
        lab.close()
        stranger.close()
    finally:
        for node in nodes:
            node.shutdown()
        for session in sessions:
            session.close()
        robot.close()
        team_router.close()
