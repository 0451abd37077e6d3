"""The optional views: the 3D robot (real viser + a real URDF through yourdfpy) and the plots (real rerun)."""

from __future__ import annotations

import asyncio
import contextlib
import time
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
import websockets.sync.client as ws_client

import schemas
from server.config import RobotDescription, ServerConfig
from server.hub import Hub, HubMessage
from tests.support import free_port
from tests.waiting import wait_for

WOLFGANG_JOINTS = ["HeadPan", "HeadTilt", "LKnee", "RKnee", "LElbow", "RElbow"]


def joint_states(names: list[str], positions: list[float], robot: str = "r1") -> HubMessage:
    msg = schemas.make("sensor_msgs/msg/JointState", name=names, position=positions)
    return HubMessage(robot, "joint_states", msg.__msgtype__, time.time(), msg, "test")


async def _until(condition, timeout: float = 30.0) -> None:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError("condition not met in time")
        await asyncio.sleep(0.05)


def _wolfgang_3d_config(testdata: Path) -> ServerConfig:
    """The 3D view on a free port, every robot drawn as the Wolfgang-OP (meshes through its package:// path)."""
    wolfgang = testdata / "robots" / "wolfgang"
    return ServerConfig(robot3d=True, robot3d_port=free_port(), descriptions={
        "*": RobotDescription(wolfgang / "urdf" / "robot.urdf", {"wolfgang_description": wolfgang})})


@pytest.mark.slow
def test_robot3d_moves_the_urdf_joints(testdata: Path) -> None:
    from server.robot3d import Robot3DView

    config = _wolfgang_3d_config(testdata)

    async def main() -> None:
        hub = Hub()
        hub.bind(asyncio.get_running_loop())
        view = Robot3DView(hub, config)
        await view.start()
        try:
            page = await asyncio.to_thread(httpx.get, f"http://127.0.0.1:{view.port}/", timeout=10)
            assert page.status_code == 200 and "<html" in page.text.lower()  # viser's bundled client
            hub.publish(joint_states([*WOLFGANG_JOINTS, "not_a_joint"], [0.5, -0.3, 1.0, 1.1, 0.2, 0.4, 9.0]))
            await _until(lambda: "r1" in view.robots, 60.0)  # its URDF is loaded at once...
            assert view.robots["r1"].updates == 0 and "r1" in view._unshown  # ...but nobody looks: not posed
            # a viewer (the dashboard's proxy: a WebSocket without Origin) gets the newest pose at once
            import viser

            viewer = await asyncio.to_thread(ws_client.connect, f"ws://127.0.0.1:{view.port}", open_timeout=10,
                                             subprotocols=[f"viser-v{viser.__version__}"])
            try:
                await _until(lambda: "r1" in view.robots and view.robots["r1"].updates > 0, 60.0)
            finally:
                viewer.close()
            model = view.robots["r1"]
            assert len(model.joint_names) == 20
            got = dict(zip(model.joint_names, model.cfg, strict=True))
            assert got["HeadPan"] == pytest.approx(0.5) and got["RKnee"] == pytest.approx(1.1)
            assert not view.failed
        finally:
            await view.stop()

    asyncio.run(main())


@pytest.mark.slow
def test_robot3d_tells_live_and_replayed_robots_apart_and_lets_a_closed_replay_go(testdata: Path) -> None:
    """Each figure carries its name above it and its kind's colour (a replayed one purple, its label higher);
    a figure hides and shows; a robot the hub forgets (a closed replay's) leaves the scene with its label."""
    from server.robot3d import LABEL_HEIGHT_M, Robot3DView

    config = _wolfgang_3d_config(testdata)

    async def main() -> None:
        hub = Hub()
        hub.bind(asyncio.get_running_loop())
        view = Robot3DView(hub, config)
        await view.start()
        try:
            hub.publish(joint_states(["HeadPan"], [0.1], robot="r1"))
            hub.publish(joint_states(["HeadPan"], [0.2], robot="replay.r1"))
            await _until(lambda: {"r1", "replay.r1"} <= view.robots.keys(), 60.0)
            figures = {f["name"]: f for f in view.figures()}
            assert figures["r1"]["kind"] == "live" and figures["r1"]["color"] == ""  # the URDF's own colours
            assert figures["replay.r1"]["kind"] == "replay" and figures["replay.r1"]["color"] == "#9b2fd1"
            nodes = view.server.scene._handle_from_node_name
            live_label, replay_label = nodes["/r1/label"], nodes["/replay.r1/label"]
            assert live_label.text == "r1" and replay_label.text == "replay.r1"
            assert replay_label.position[2] == pytest.approx(LABEL_HEIGHT_M["replay"])
            assert replay_label.position[2] > live_label.position[2] + 0.1

            assert view.set_visible("replay.r1", False)
            assert not view.robots["replay.r1"].frame.visible and view.robots["r1"].frame.visible
            assert [f["visible"] for f in view.figures()] == [True, False]
            view.set_visible("replay.r1", True)
            assert view.robots["replay.r1"].frame.visible

            hub.forget("replay.r1")  # the replay closed
            await _until(lambda: "replay.r1" not in view.robots)
            assert "/replay.r1" not in nodes and "/replay.r1/label" not in nodes and "/r1/label" in nodes
            assert [f["name"] for f in view.figures()] == ["r1"]
        finally:
            await view.stop()

    asyncio.run(main())


def test_robot3d_missing_urdf_is_reported_not_raised(tmp_path: Path) -> None:
    from server.robot3d import Robot3DView

    config = ServerConfig(robot3d=True, robot3d_port=free_port(),
                          descriptions={"*": RobotDescription(tmp_path / "nope.urdf")})

    async def main() -> None:
        hub = Hub()
        view = Robot3DView(hub, config)
        await view.start()
        try:
            hub.publish(joint_states(["a"], [0.0]))
            await _until(lambda: "r1" in view.failed)
            assert "nope.urdf" in view.failed["r1"]
        finally:
            await view.stop()

    asyncio.run(main())


def _plots_config(plots_max_hz: float) -> ServerConfig:
    return ServerConfig(plots=True, plots_web_port=free_port(), plots_grpc_port=free_port(), plots_max_hz=plots_max_hz)


@contextlib.asynccontextmanager
async def _running_feed(config: ServerConfig) -> AsyncIterator[tuple[Hub, Any]]:
    """A hub and a started PlotFeed on it (real rerun gRPC and viewer servers), stopped afterwards."""
    from server.plots import PlotFeed

    hub = Hub()
    feed = PlotFeed(hub, config)
    await feed.start()
    try:
        yield hub, feed
    finally:
        await feed.stop()


@pytest.mark.slow
def test_plots_feed_rerun_and_serve_the_viewer() -> None:
    config = _plots_config(plots_max_hz=50)

    async def main() -> None:
        async with _running_feed(config) as (hub, feed):
            for i in range(20):
                hub.publish(joint_states(["HeadPan"], [0.01 * i]))
                await asyncio.sleep(0.005)
            await _until(lambda: feed.logged >= 1)
            assert feed.topics == {"r1": []}  # the curated series only, until a topic is chosen
            series = feed.status()["series"]
            # a topic chosen in the panel: every number of it, a tab of its own; unchosen, the tab goes
            feed.choose("*", "joint_states", True)
            hub.publish(joint_states(["HeadPan"], [0.5]))
            await _until(lambda: feed.status()["series"] > series)
            assert feed.topics == {"r1": ["joint_states"]}
            feed.choose("*", "joint_states", False)
            assert feed.topics == {"r1": []} and not feed.chosen
            viewer = await asyncio.to_thread(httpx.get, f"http://127.0.0.1:{config.plots_web_port}/", timeout=10)
            assert viewer.status_code == 200

            # a replayed robot gets its tab; when its replay closes (the hub forgets it), the tab goes with it
            hub.publish(joint_states(["HeadPan"], [0.3], robot="replay.r1"))
            await _until(lambda: "replay.r1" in feed.topics)
            hub.publish(joint_states(["HeadPan"], [0.4], robot="replay.r1"))  # still queued when it closes
            hub.forget("replay.r1")
            await asyncio.sleep(0.8)  # a batch of the feed (BATCH_S) has passed: nothing of it came back
            assert feed.topics == {"r1": []} and "replay.r1" not in feed.status()["robots"]

    asyncio.run(main())


def _message(topic: str, typename: str, **fields: object) -> HubMessage:
    msg = schemas.make(typename, **fields)
    return HubMessage("r1", topic, msg.__msgtype__, 0.0, msg, "test")


def test_plot_series_group_a_message_into_named_lines() -> None:
    from server.plot_series import RobotSeries, Series, topic_series

    robot = RobotSeries()
    diag = _message("diagnostics", "diagnostic_msgs/msg/DiagnosticArray", status=[schemas.make(
        "diagnostic_msgs/msg/DiagnosticStatus", name="r1/hcm", values=[
            schemas.make("diagnostic_msgs/msg/KeyValue", key="rate_hz/tick", value="99.5"),
            schemas.make("diagnostic_msgs/msg/KeyValue", key="rate_hz/bad", value="n/a")])])
    assert robot.series(diag) == {"loop_rates/hcm": Series(("hcm tick",), (99.5,))}

    # goals: in the joint_states order, a joint's goal holds until its next one, NaN before the first
    assert robot.series(joint_states(["HeadPan", "HeadTilt", "LKnee"], [0.1, 0.2, 0.3])) == {
        "joints/position": Series(("HeadPan", "HeadTilt", "LKnee"), (0.1, 0.2, 0.3))}

    def goals(names: list[str], positions: list[float]) -> HubMessage:
        point = schemas.make("trajectory_msgs/msg/JointTrajectoryPoint", positions=positions)
        return _message("motor_goals", "trajectory_msgs/msg/JointTrajectory", joint_names=names, points=[point])

    first = robot.series(goals(["LKnee"], [1.0]))["joints/goal"]
    assert first.names == ("HeadPan", "HeadTilt", "LKnee") and np.isnan(first.values[:2]).all()
    assert first.values[2] == 1.0
    assert robot.series(goals(["HeadTilt"], [0.5]))["joints/goal"].values[1:] == (0.5, 1.0)

    imu = robot.series(_message("imu/data", "sensor_msgs/msg/Imu", angular_velocity=schemas.make(
        "geometry_msgs/msg/Vector3", x=0.0, y=-2.5, z=0.0)))
    assert imu["imu/angular_velocity"] == Series(("gyro x", "gyro y", "gyro z"), (0.0, -2.5, 0.0))

    # any numeric field of any topic, grouped by parent; top-level numbers under the topic itself
    game = topic_series(_message("gamestate", "humanoid_league_msgs/msg/GameState", own_score=2, rival_score=1))
    top = game["topics/gamestate"]
    assert dict(zip(top.names, top.values, strict=True))["own_score"] == 2.0
    assert "seconds_remaining" in top.names
    js = topic_series(joint_states(["HeadPan"], [0.25]))
    assert js == {"topics/joint_states/position": Series(("HeadPan",), (0.25,))}
    image = _message("camera/image", "sensor_msgs/msg/CompressedImage", format="jpeg")
    assert topic_series(image) == {}  # pictures are not plotted


def _robot_state(state: int) -> HubMessage:
    msg = schemas.make("humanoid_league_msgs/msg/RobotControlState", state=state)
    return HubMessage("r1", "robot_state", msg.__msgtype__, time.time(), msg, "test")


def test_state_lanes_name_the_hcm_and_game_states() -> None:
    from server.plot_series import states_of

    hcm = schemas.constants("humanoid_league_msgs/msg/RobotControlState")
    assert states_of(_robot_state(hcm["GETTING_UP"])) == {"lanes/hcm": "GETTING_UP"}
    game = schemas.constants("humanoid_league_msgs/msg/GameState")
    msg = _message("gamestate", "humanoid_league_msgs/msg/GameState", game_state=game["GAMESTATE_PLAYING"],
                   secondary_state=game["STATE_PENALTYKICK"], penalized=True)
    assert states_of(msg) == {"lanes/game": "PLAYING / PENALTYKICK", "lanes/penalized": "penalized"}
    assert states_of(_robot_state(99)) == {"lanes/hcm": "state 99"}  # a newer HCM's state still gets a lane
    assert states_of(joint_states(["HeadPan"], [0.0])) == {}


@pytest.mark.slow
def test_plots_log_every_state_change_however_short_and_only_changes() -> None:
    """Numbers are thinned to plots_max_hz; a state held for 5 ms (FALLING) must still reach its lane."""
    hcm = schemas.constants("humanoid_league_msgs/msg/RobotControlState")

    async def main() -> None:
        async with _running_feed(_plots_config(plots_max_hz=1)) as (hub, feed):
            for name in ("CONTROLLABLE", "CONTROLLABLE", "FALLING", "FALLEN", "FALLEN", "GETTING_UP", "CONTROLLABLE"):
                hub.publish(_robot_state(hcm[name]))
                await asyncio.sleep(0.005)
            await _until(lambda: feed.logged >= 7)
            assert feed.state_changes == 5, feed.status()

    asyncio.run(main())


@pytest.mark.slow
def test_plots_viewer_is_served_through_the_dashboard_and_cannot_call_out(tmp_path: Path) -> None:
    from tests.dashboard_server import dashboard_server

    grpc_port = free_port()
    args = ["--no-live", "--no-telemetry", "--plots", "--plots-port", str(free_port()),
            "--plots-grpc-port", str(grpc_port)]
    with dashboard_server(args, tmp_path) as server:
        page = wait_for(lambda: _ok(f"{server.url}/plots/viewer/index.html"), 30.0, 0.2, what="the viewer's page")
        policy = page.headers["content-security-policy"]
        assert "default-src 'self'" in policy
        assert "connect-src 'self' data: blob:;" in policy  # the gRPC stream comes through this server too
        assert page.headers["x-content-type-options"] == "nosniff"
        assert "re_viewer.js" in page.text and "fonts.googleapis.com" not in page.text
        wasm = httpx.get(f"{server.url}/plots/viewer/re_viewer_bg.wasm", timeout=30)
        assert wasm.status_code == 200 and wasm.headers["content-type"] == "application/wasm"
        assert wasm.content[:4] == b"\0asm"
        # a browser that has the file already revalidates it for nothing (the proxy then reads no 43 MB)
        again = httpx.get(f"{server.url}/plots/viewer/re_viewer_bg.wasm", timeout=30,
                          headers={"If-None-Match": wasm.headers["etag"]})
        assert again.status_code == 304 and not again.content and again.headers["etag"] == wasm.headers["etag"]
        other = httpx.get(f"{server.url}/plots/viewer/re_viewer.js", timeout=30,
                          headers={"If-None-Match": wasm.headers["etag"]})
        assert other.status_code == 200 and other.headers["etag"] != wasm.headers["etag"]
        assert httpx.get(f"{server.url}/plots/viewer/..%2Fapi%2Fconfig", timeout=10).status_code == 404
        # choosing a topic to plot whole
        chosen = server.http.post(f"{server.url}/api/plots/topics", json={"topic": "gamestate"}, timeout=10)
        assert chosen.status_code == 200 and chosen.json()["chosen"] == [{"robot": "*", "topic": "gamestate"}]
        assert server.http.post(f"{server.url}/api/plots/topics", json={"topic": " "}, timeout=10).status_code == 422


def _ok(url: str) -> httpx.Response | None:
    try:
        response = httpx.get(url, timeout=10)
    except httpx.HTTPError:
        return None
    return response if response.status_code == 200 else None
