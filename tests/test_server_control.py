"""The control API against real nodes over Zenoh: penalize (service) and play animation (action)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import schemas
from robot_nodes.runtime import BusConfig, Node, ServerGoal
from tests.dashboard_server import RunningServer, dashboard_server


class PenaltyAndAnimationStand(Node):
    """Serves manual_penalize and the animation action like the HCM and the animation node would."""

    __test__ = False
    name = "controlstand"

    def setup(self) -> None:
        self.penalized = False
        self.goals: list[str] = []
        self.service("manual_penalize", self.on_penalize)
        self.action_server("animation", self.on_goal)

    def on_penalize(self, request: Any) -> Any:
        consts = schemas.constants("humanoid_league_msgs/srv/ManualPenalize_Request")
        if request.penalize == consts["SWITCH"]:
            self.penalized = not self.penalized
        else:
            self.penalized = request.penalize == consts["ON"]
        return schemas.make("humanoid_league_msgs/srv/ManualPenalize_Response", penalized=self.penalized)

    def on_goal(self, goal: ServerGoal) -> str | None:
        if goal.goal.animation not in ("stand", "wave"):
            return f"no animation named {goal.goal.animation!r}"
        self.goals.append(goal.goal.animation)
        goal.succeed(schemas.make("humanoid_league_msgs/action/PlayAnimation_Result", successful=True))
        return None


@pytest.fixture
def server(router_endpoint: str, tmp_path: Path) -> Any:
    with dashboard_server(["--connect", router_endpoint, "--no-telemetry"], tmp_path) as running:
        yield running


def test_penalize_and_animation(server: RunningServer, bus: BusConfig) -> None:
    node = PenaltyAndAnimationStand("r5", bus).start()
    try:
        url = f"{server.url}/api/robots/r5"
        reply = server.http.post(f"{url}/penalize", json={"penalize": "on"}, timeout=15)
        assert reply.status_code == 200 and reply.json() == {"robot": "r5", "penalized": True}
        reply = server.http.post(f"{url}/penalize", json={"penalize": "switch"}, timeout=15)
        assert reply.json()["penalized"] is False and node.penalized is False
        assert server.http.post(f"{url}/penalize", json={"penalize": "maybe"}, timeout=15).status_code == 422

        reply = server.http.post(f"{url}/animation-play", json={"animation": "wave", "wait": True}, timeout=30)
        assert reply.status_code == 200, reply.text
        assert reply.json()["status"] == "SUCCEEDED" and reply.json()["result"]["successful"] is True
        reply = server.http.post(f"{url}/animation-play", json={"animation": "moonwalk"}, timeout=30)
        assert reply.status_code == 409 and "moonwalk" in reply.json()["detail"]
        assert node.goals == ["wave"]
    finally:
        node.shutdown()
    reply = server.http.post(f"{server.url}/api/robots/nobody/penalize", json={"penalize": "on"}, timeout=30)
    assert reply.status_code == 504 and "no answer" in reply.json()["detail"]
    reply = server.http.get(f"{server.url}/api/robots/nobody/params/hcm", timeout=30)
    assert reply.status_code == 504 and "did not answer" in reply.json()["detail"]


def test_a_command_to_a_robot_gone_silent_fails_at_once(server: RunningServer, bus: BusConfig) -> None:
    """During a cut link the robot cannot answer: the control API says so instead of waiting for a timeout."""
    from tests.teststand import TestStand
    from tests.waiting import wait_for

    stand = TestStand("r5", bus, overrides={"rate_hz": 20.0}).start()
    try:
        wait_for(lambda: server.http.get(f"{server.url}/api/robots/r5/params").status_code == 200, 20.0, 0.2,
                 "the robot answers")
        # heard by the server too (a robot never heard is asked as usual, not refused): the params answer can
        # come before the server's first message from it
        wait_for(lambda: any(r["robot"] == "r5" and r["status"] == "ok"
                             for r in server.http.get(f"{server.url}/api/robots").json()), 20.0, 0.1, "r5 heard")
    finally:
        stand.shutdown()
    wait_for(lambda: any(r["robot"] == "r5" and r["status"] != "ok"
                         for r in server.http.get(f"{server.url}/api/robots").json()), 20.0, 0.1, "r5 gone stale")
    for method, path, body in (("GET", "params", None), ("POST", "penalize", {"penalize": "on"}),
                               ("POST", "teleop", {"x": 0.1})):
        reply = server.http.request(method, f"{server.url}/api/robots/r5/{path}", json=body)
        assert reply.status_code == 503 and "silent" in reply.json()["detail"], (path, reply.text)
