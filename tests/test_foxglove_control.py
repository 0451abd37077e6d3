"""Control through the Foxglove endpoint (issue 17 points 4, 5, 8): parameters with the nodes' own validation and
revisions, manual_penalize and play_animation as services, cmd_vel from a client with the teleop panel's limits and
dead-man stop, all only with the dashboard's token and only in the lab; in match mode nothing of it is offered and
nothing reaches a robot. The robot is real nodes composed in one process (a pose stand, the pause node with its
manual_penalize service, the animation node with its action server); the client is the real Foxglove client."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import zenoh

import schemas
from robot_nodes.animation.node import AnimationNode
from robot_nodes.hcm.pause import PauseNode
from robot_nodes.runtime import BusConfig, Node, ParameterClient, open_session
from server.foxglove.parameters import RobotParameters
from server.zenoh_link import ZenohLink
from tests.dashboard_server import RunningServer, dashboard_server
from tests.foxglove_node import foxglove_url, run_session
from tests.foxglove_stand import PoseStand
from tests.support import free_port
from tests.test_match_mode import _assert_only_listening, robot_overview_datagrams
from tests.waiting import wait_for
from wire.keys import topic_key

ROBOT = "r1"
TWIST = "geometry_msgs/msg/Twist"
CONTROL = {"parameters", "services", "clientPublish", "connectionGraph", "playbackControl"}


@pytest.fixture
def robot(bus: BusConfig) -> Iterator[dict[str, Node]]:
    """One robot's nodes composed in one process, sharing one Zenoh session."""
    session = open_session(bus)
    nodes: dict[str, Node] = {"posestand": PoseStand(ROBOT, session).start(),
                              "pause": PauseNode(ROBOT, session).start(),
                              "animation": AnimationNode(ROBOT, session).start()}
    yield nodes
    for node in nodes.values():
        node.shutdown()
    session.close()


@pytest.fixture
def lab(router_endpoint: str, robot: dict[str, Node], tmp_path: Path) -> Iterator[tuple[RunningServer, str]]:
    with dashboard_server(["--connect", router_endpoint, "--no-telemetry", "--foxglove-port", str(free_port())],
                          tmp_path) as server:
        url = wait_for(lambda: foxglove_url(server.output()), timeout=30, what="the foxglove banner")
        assert url is not None
        wait_for(lambda: any(r["robot"] == ROBOT for r in server.http.get(f"{server.url}/api/robots").json()),
                 timeout=30, interval=0.2, what="r1 heard")
        yield server, url


def with_token(server: RunningServer, url: str) -> str:
    return f"{url}/?token={server.token}"


def results(got: dict[str, Any], op: str) -> list[dict[str, Any]]:
    assert got["errors"] == [], got["errors"]
    return [r for r in got["results"] if r["op"] == op]


def values(parameters: list[dict[str, Any]]) -> dict[str, Any]:
    return {p["name"]: p["value"] for p in parameters}


def test_parameters_are_read_and_set_with_the_nodes_validation_and_changes_elsewhere_are_pushed(
        lab: tuple[RunningServer, str], client: zenoh.Session, robot: dict[str, Node]) -> None:
    server, url = lab
    stand = robot["posestand"]
    elsewhere = ParameterClient(client, ROBOT)

    def change_elsewhere() -> None:  # another dashboard, the CLI: once Foxglove's write is on the node
        wait_for(lambda: stand.params.x == 3.5, timeout=30, what="Foxglove's write applied")
        elsewhere.set("posestand", {"y": 1.5})

    changer = threading.Thread(target=change_elsewhere, daemon=True)
    changer.start()
    got = run_session(with_token(server, url), [
        {"op": "getParameters", "names": []},
        {"op": "subscribeParameterUpdates", "names": ["/r1/posestand/y"]},
        {"op": "setParameters", "parameters": [{"name": "/r1/posestand/x", "value": 3.5, "type": "float64"}]},
        {"op": "setParameters", "parameters": [{"name": "/r1/posestand/x", "value": 99.0, "type": "float64"}]},
        {"op": "setParameters", "parameters": [{"name": "/r1/posestand/model", "value": "wolfgang"}]},
        {"op": "waitParameter", "name": "/r1/posestand/y", "value": 1.5}])
    changer.join(30)
    listed, written, out_of_range, startup = [values(r["parameters"]) for r in results(got, "getParameters") +
                                              results(got, "setParameters")]
    # every node of the robot, named /<robot>/<node>/<param>
    assert listed["/r1/posestand/x"] == 1.0 and listed["/r1/posestand/model"] == "minibot"
    assert "/r1/animation/rate_hz" in listed
    assert written == {"/r1/posestand/x": 3.5} and stand.params.x == 3.5
    # refused by the node: the old value stays, and the clients are told why
    assert out_of_range == {"/r1/posestand/x": 3.5} and startup == {"/r1/posestand/model": "minibot"}
    assert stand.params.x == 3.5 and stand.params.model == "minibot"
    reasons = [s["message"] for s in got["statuses"]]
    assert any("x=99.0 is out of range [-6.0, 6.0]" in r for r in reasons), reasons
    assert any("model is read once when posestand starts" in r for r in reasons), reasons
    # pushed: the change made elsewhere reached the subscribed client (waitParameter returned)
    assert any(p["name"] == "/r1/posestand/y" and p["value"] == 1.5 for m in got["parameterValues"]
               for p in m["parameters"] if "id" not in m)
    # without the token: no parameters at all
    view = run_session(url, [{"op": "getParameters", "names": []}], seconds=3)
    assert "parameters" not in view["serverInfo"]["capabilities"]
    assert any("does not support parameters" in s["message"] for s in view["statuses"]), view["statuses"]


def test_a_write_based_on_a_value_changed_meanwhile_is_refused_as_the_panel_refuses_it(
        bus: BusConfig, client: zenoh.Session, robot: dict[str, Node]) -> None:
    """The revision check: the endpoint writes with the revision it last told its clients (here it follows no
    change events, so it has not heard of the change made elsewhere); the node refuses, the value stays."""
    link = ZenohLink(bus, match_mode=False)
    told: list[str] = []
    parameters = RobotParameters(link, lambda: [ROBOT], told.append)
    try:
        assert values_of(parameters.get(["/r1/posestand/theta"])) == {"/r1/posestand/theta": 0.5}
        ParameterClient(client, ROBOT).set("posestand", {"theta": -1.0})
        after = parameters.set([parameter("/r1/posestand/theta", 2.0)])
        assert values_of(after) == {"/r1/posestand/theta": -1.0}  # the value someone else set stays
        assert robot["posestand"].params.theta == -1.0
        assert len(told) == 1 and "was changed meanwhile" in told[0], told
        again = parameters.set([parameter("/r1/posestand/theta", 2.0)])  # now based on what it was told
        assert values_of(again) == {"/r1/posestand/theta": 2.0} and robot["posestand"].params.theta == 2.0
    finally:
        link.close()


def parameter(name: str, value: float) -> Any:
    import foxglove

    return foxglove.Parameter(name, value=value, type=foxglove.ParameterType.Float64)


def values_of(parameters: list[Any]) -> dict[str, Any]:
    return {p.name: p.get_value() for p in parameters}


class CmdVel:
    """What reaches the robot on its cmd_vel key: (time, x, y, yaw) per Twist."""

    def __init__(self, session: zenoh.Session) -> None:
        self.got: list[tuple[float, float, float, float]] = []
        self._sub = session.declare_subscriber(topic_key(ROBOT, "cmd_vel"), self._on)

    def _on(self, sample: zenoh.Sample) -> None:
        twist = schemas.decode(sample.payload.to_bytes(), TWIST)
        self.got.append((time.monotonic(), twist.linear.x, twist.linear.y, twist.angular.z))


def test_services_and_cmd_vel_in_the_lab_with_the_teleop_limits_and_the_dead_man_stop(
        lab: tuple[RunningServer, str], client: zenoh.Session, robot: dict[str, Node]) -> None:
    server, url = lab
    bare = PoseStand("r3", client).start()  # a robot without HCM or animation node: no services for it
    wait_for(lambda: any(r["robot"] == "r3" for r in server.http.get(f"{server.url}/api/robots").json()),
             timeout=30, interval=0.2, what="r3 heard")
    cmd_vel = CmdVel(client)
    paused = []
    client.declare_subscriber(topic_key(ROBOT, "paused"),
                              lambda s: paused.append(schemas.decode(s.payload.to_bytes(), "std_msgs/msg/Bool").data))
    twist_text = schemas.msgdef(TWIST)
    drive = {"linear": {"x": 0.3, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.5}}
    got = run_session(with_token(server, url), [
        {"op": "waitService", "service": "/r1/manual_penalize"},
        {"op": "waitService", "service": "/r1/play_animation"},
        {"op": "callService", "service": "/r1/manual_penalize", "request": {"penalize": 1}},
        {"op": "callService", "service": "/r1/play_animation", "request": {"animation": "init", "hcm": False}},
        {"op": "callService", "service": "/r1/play_animation", "request": {"animation": "init", "hcm": True}},
        {"op": "callService", "service": "/r1/play_animation", "request": {"animation": "no_such", "hcm": False}},
        {"op": "publish", "topic": "/r1/cmd_vel", "encoding": "json", "schemaName": TWIST, "message": drive,
         "hz": 10, "count": 10},
        {"op": "wait", "ms": 800},
        {"op": "publish", "topic": "/r1/cmd_vel", "encoding": "cdr", "schemaName": TWIST, "schema": twist_text,
         "message": {**drive, "linear": {"x": 5.0, "y": 0.0, "z": 0.0}}, "hz": 10, "count": 3},
        {"op": "publish", "topic": "/r1/cmd_vel", "encoding": "cdr", "schemaName": TWIST, "schema": twist_text,
         "message": {**drive, "linear": {"x": -0.2, "y": 0.1, "z": 0.0}}, "hz": 10, "count": 5, "keep": True},
        {"op": "wait", "ms": 1500},
        {"op": "publish", "topic": "/r2/joint_states", "encoding": "json", "schemaName": TWIST, "message": drive,
         "hz": 10, "count": 1}])
    bare.shutdown()
    assert {"/r1/manual_penalize", "/r1/play_animation"} <= set(got["services"])
    assert not any(name.startswith("/r3/") for name in got["services"]), got["services"]
    penalize, play, hcm, unknown = (r.get("response", r.get("failure")) for r in results(got, "callService"))
    assert penalize == {"penalized": True} and wait_for(lambda: True in paused, timeout=10, what="paused")
    assert play == {"successful": True, "message": "accepted: playing"}
    assert "hcm goals come from the HCM only" in hcm
    assert unknown["successful"] is False and "no_such" in unknown["message"]
    # cmd_vel: the JSON drive reached the robot, then zero once the client let go (unadvertise: at once)
    moving = [g for g in cmd_vel.got if g[1:] == pytest.approx((0.3, 0.0, 0.5))]
    assert len(moving) >= 8, cmd_vel.got
    after = [g for g in cmd_vel.got if g[0] > moving[-1][0]]
    assert after and after[0][1:] == (0.0, 0.0, 0.0), cmd_vel.got
    # out of the teleop limits: refused whole, with the reason, nothing of it sent
    assert not any(abs(g[1]) > 1.0 for g in cmd_vel.got)
    reasons = [s["message"] for s in got["statuses"]]
    assert any("/r1/cmd_vel: not sent" in r and "less than or equal to 1" in r for r in reasons), reasons
    # a client that stops publishing without letting go (CDR this time): the dead-man stop zeroes the robot
    reverse = [g for g in cmd_vel.got if g[1:] == pytest.approx((-0.2, 0.1, 0.5))]
    assert reverse, cmd_vel.got
    assert cmd_vel.got[-1][1:] == (0.0, 0.0, 0.0) and cmd_vel.got[-1][0] > reverse[-1][0]
    assert any("'/r2/joint_states'" in r and "not published" in r for r in reasons), reasons
    # without the token: it shows, nothing more
    view = run_session(url, [{"op": "publish", "topic": "/r1/cmd_vel", "encoding": "json", "schemaName": TWIST,
                              "message": drive, "hz": 10, "count": 2}, {"op": "wait", "ms": 500}], seconds=3)
    assert not CONTROL - {"connectionGraph"} & set(view["serverInfo"]["capabilities"])
    assert view["services"] == [] and any("clientPublish" in s["message"] for s in view["statuses"])


def test_match_mode_offers_no_control_to_anyone_and_nothing_reaches_a_robot(
        router_endpoint: str, client: zenoh.Session, tmp_path: Path) -> None:
    heard: list[str] = []
    listener = client.declare_subscriber("pitchside/**", lambda s: heard.append(str(s.key_expr)))
    data_listener = client.declare_subscriber(topic_key("*", "**"), lambda s: heard.append(str(s.key_expr)))
    telemetry_port = free_port(socket.SOCK_DGRAM)
    router_port = int(router_endpoint.rsplit(":", 1)[1])
    args = ["--match", "--allow-dev-key", "--connect", router_endpoint, "--telemetry-host", "127.0.0.1",
            "--telemetry-port", str(telemetry_port), "--foxglove-port", str(free_port())]
    robot = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    stop = threading.Event()

    def send_overviews() -> None:  # the robot is there, over one-way telemetry
        while not stop.is_set():
            for packet in robot_overview_datagrams(ROBOT):
                robot.sendto(packet, ("127.0.0.1", telemetry_port))
            stop.wait(0.2)

    sender = threading.Thread(target=send_overviews, daemon=True)
    try:
        with dashboard_server(args, tmp_path) as server:
            sender.start()
            wait_for(lambda: server.http.get(f"{server.url}/api/robots").json(), timeout=20, what="r1 listed")
            url = wait_for(lambda: foxglove_url(server.output()), timeout=30, what="the foxglove banner")
            assert url is not None
            twist = {"linear": {"x": 0.3, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}
            attempts = [{"op": "waitChannel", "topic": "/r1/overview"},
                        {"op": "getParameters", "names": [], "noAnswer": True},
                        {"op": "setParameters", "parameters": [{"name": "/r1/hcm/record_mode", "value": True}],
                         "noAnswer": True},
                        {"op": "publish", "topic": "/r1/cmd_vel", "encoding": "json", "schemaName": TWIST,
                         "message": twist, "hz": 10, "count": 5},
                        {"op": "wait", "ms": 1000}]
            for door in (f"{url}/?token={server.token}", url):  # with the token too
                got = run_session(door, attempts, seconds=5)
                assert got["errors"] == [] and got["serverInfo"]["capabilities"] == ["assets"], got
                assert got["services"] == [] and "/r1/overview" in got["channels"]
                refused = " ".join(s["message"] for s in got["statuses"])
                assert "does not support parameters" in refused and "clientPublish" in refused, got["statuses"]
            _assert_only_listening(server, telemetry_port, router_port)
            assert server.process.poll() is None
        time.sleep(0.5)  # anything the server had sent would have arrived by now
        assert heard == [], heard
    finally:
        stop.set()
        if sender.is_alive():
            sender.join(5)
        robot.close()
        listener.undeclare()
        data_listener.undeclare()

