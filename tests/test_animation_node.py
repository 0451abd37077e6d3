"""The animation node over a real Zenoh router: goals, animation steps to the HCM, feedback, preemption, cancel."""

from __future__ import annotations

import itertools
import json
import math
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import zenoh

import schemas
from robot_nodes.animation.node import NO_TORQUE_REQUEST, AnimationNode
from robot_nodes.runtime import BusConfig, ClientGoal, GoalStatus, Node
from tests.waiting import wait_for

pytestmark = pytest.mark.realtime

HEAD = {"HeadPan": 0.1, "HeadTilt": -0.2, "LKnee": 0.5}
NOD = {
    "name": "nod", "author": "test", "keyframes": [
        {"duration": 0.3, "pause": 0.1, "goals": {"HeadTilt": -30.0}, "name": "down"},
        {"duration": 0.3, "goals": {"HeadTilt": 10.0, "HeadPan": 15.0}, "torque": {"HeadPan": 1.0}, "name": "up"},
    ],
}
SLOW = {"name": "slow_look", "keyframes": [{"duration": 4.0, "goals": {"HeadPan": 60.0}},
                                           {"duration": 4.0, "goals": {"HeadPan": -60.0}}]}
KNEE = {"name": "knee_bend", "keyframes": [{"duration": 0.3, "goals": {"LKnee": 20.0}}]}


class Body(Node):
    """Stands where cm730 and the HCM would: publishes joint_states, records the animation steps, sends goals."""

    name = "body"

    def setup(self) -> None:
        self.positions: dict[str, float] = {}
        self.received: list[Any] = []
        self.joint_states = self.publisher("joint_states")
        self.subscribe("animation", self.received.append)
        self.timer(self.publish_state, rate_hz=50.0)
        self.client = self.action_client("animation")

    def publish_state(self) -> None:
        if self.positions:
            self.joint_states.publish(schemas.make("sensor_msgs/msg/JointState", name=list(self.positions),
                                                   position=list(self.positions.values())))

    def play(self, animation: str, hcm: bool = False, timeout: float = 10.0) -> ClientGoal:
        goal = schemas.make("humanoid_league_msgs/action/PlayAnimation_Goal", animation=animation, hcm=hcm)
        return self.client.send_goal(goal, timeout=timeout)


def write(folder: Path, filename: str, data: dict[str, Any] | str) -> Path:
    path = folder / filename
    path.write_text(data if isinstance(data, str) else json.dumps(data))
    return path


@pytest.fixture
def animations(tmp_path: Path) -> Path:
    folder = tmp_path / "animations"
    (folder / "misc").mkdir(parents=True)
    write(folder / "misc", "nod.json", NOD)
    write(folder, "slow_look.json", SLOW)
    write(folder, "knee.json", KNEE)
    return folder


@pytest.fixture
def body(robot_bus: BusConfig | zenoh.Session) -> Iterator[Body]:
    """Stands in for the servo bus and the HCM: composed with the animation node, or in a session of its own."""
    node = Body(bus=robot_bus)
    node.positions = dict(HEAD)
    node.start()
    yield node
    node.shutdown()


@pytest.fixture
def player(robot_bus: BusConfig | zenoh.Session, animations: Path, body: Body) -> Iterator[AnimationNode]:
    node = AnimationNode(bus=robot_bus, overrides={"animation_dir": str(animations)})
    node.start()
    wait_for(lambda: node.joint_positions is not None and "LKnee" in node.joint_positions, 10.0,
             what="joint_states at the animation node")
    yield node
    node.shutdown()


def steps_of(body: Body, joint_names: list[str]) -> list[Any]:
    return [m for m in list(body.received) if list(m.position.joint_names) == joint_names]


def test_plays_animation_to_the_end(player: AnimationNode, body: Body) -> None:
    goal = body.play("nod")
    assert goal.wait_accepted(10.0), goal.reason
    status, result = goal.wait_result(20.0)
    assert status == GoalStatus.SUCCEEDED and result.successful
    steps = wait_for(lambda: [m for m in steps_of(body, ["HeadTilt", "HeadPan"]) if m.last] and
                     steps_of(body, ["HeadTilt", "HeadPan"]), 10.0, what="the last animation step")
    assert steps[0].first and not any(m.first for m in steps[1:])
    assert steps[-1].last and not any(m.last for m in steps[:-1])
    assert not any(m.hcm for m in steps)
    assert len(steps) >= 10  # 0.7 s at 100 Hz, with room for a loaded machine
    first = steps[0].position.points[0].positions
    assert list(first) == pytest.approx([HEAD["HeadTilt"], HEAD["HeadPan"]])  # starts at the measured pose
    end = steps[-1].position.points[0]
    assert list(end.positions) == pytest.approx([math.radians(10.0), math.radians(15.0)])
    # torque of keyframe "up" applies at its end: HeadPan on, HeadTilt without a request
    assert list(end.effort) == [NO_TORQUE_REQUEST, 1.0]
    assert len(steps[0].position.points[0].effort) == 0
    percents = [f.percent_done for f in goal.feedback]
    assert percents and percents[-1] == pytest.approx(100.0)
    assert all(b >= a for a, b in itertools.pairwise(percents))
    tilt = [m.position.points[0].positions[0] for m in steps]
    assert min(tilt) >= math.radians(-30.0) - 1e-6  # no overshoot below the "down" keyframe


def test_hcm_goal_preempts_normal_goal(player: AnimationNode, body: Body) -> None:
    normal = body.play("slow_look")
    assert normal.wait_accepted(10.0), normal.reason
    wait_for(lambda: steps_of(body, ["HeadPan"]), 10.0, what="steps of the normal animation")
    hcm = body.play("knee_bend", hcm=True)
    assert hcm.wait_accepted(10.0), hcm.reason
    status, _ = normal.wait_result(10.0)
    assert status == GoalStatus.ABORTED  # preempted (ROS 2 has no status of its own for it)
    status, result = hcm.wait_result(10.0)
    assert status == GoalStatus.SUCCEEDED and result.successful
    knee = wait_for(lambda: [m for m in steps_of(body, ["LKnee"]) if m.last] and steps_of(body, ["LKnee"]), 10.0)
    assert knee[0].first and all(m.hcm for m in knee)
    assert knee[-1].position.points[0].positions[0] == pytest.approx(math.radians(20.0))
    assert not any(m.last for m in steps_of(body, ["HeadPan"]))


def test_normal_goal_rejected_while_hcm_animation_runs(player: AnimationNode, body: Body) -> None:
    hcm = body.play("slow_look", hcm=True)
    assert hcm.wait_accepted(10.0), hcm.reason
    normal = body.play("nod")
    assert not normal.wait_accepted(10.0)
    assert "HCM animation 'slow_look' is running" in normal.reason
    assert not hcm.done
    hcm2 = body.play("knee_bend", hcm=True)  # the HCM may replace its own animation
    assert hcm2.wait_accepted(10.0), hcm2.reason
    assert hcm.wait_result(10.0)[0] == GoalStatus.ABORTED
    assert hcm2.wait_result(10.0)[0] == GoalStatus.SUCCEEDED


def test_cancel_stops_publishing(player: AnimationNode, body: Body) -> None:
    goal = body.play("slow_look")
    assert goal.wait_accepted(10.0), goal.reason
    wait_for(lambda: len(steps_of(body, ["HeadPan"])) >= 3, 10.0, what="a few steps")
    assert goal.cancel(10.0)
    status, result = goal.wait_result(10.0)
    assert status == GoalStatus.CANCELED and not result.successful
    assert player.playback is None
    published_before = player.pub.count
    # everything the node publishes from now on belongs to the next animation
    after = body.play("knee_bend")
    assert after.wait_result(20.0)[0] == GoalStatus.SUCCEEDED
    knee = wait_for(lambda: [m for m in steps_of(body, ["LKnee"]) if m.last] and steps_of(body, ["LKnee"]), 10.0)
    assert player.pub.count - published_before == len(knee)
    assert not any(m.last for m in steps_of(body, ["HeadPan"]))
    assert not goal.cancel(5.0)  # already over


def test_bad_requests_are_rejected_with_reasons(player: AnimationNode, body: Body, animations: Path) -> None:
    write(animations, "broken.json", '{"name": "broken", "keyframes": [{"goals": {"LKnee": "abc"}, "name": "k"}]}')
    goal = body.play("broken")
    assert not goal.wait_accepted(10.0)
    assert goal.reason == "broken.json: keyframe 0 ('k'): goal for joint 'LKnee' is not a number: 'abc'"
    write(animations, "syntax.json", '{"name": "syntax",\n "keyframes": [}')
    goal = body.play("syntax")
    assert not goal.wait_accepted(10.0) and goal.reason.startswith("syntax.json: invalid JSON at line 2")
    goal = body.play("no_such_animation")
    assert not goal.wait_accepted(10.0) and "no animation with this name" in goal.reason
    write(animations, "arm.json", {"name": "wave_arm", "keyframes": [{}, {"goals": {"LElbow": 30}, "name": "up"}]})
    goal = body.play("wave_arm")  # a new file is found without a restart
    assert not goal.wait_accepted(10.0)
    assert goal.reason == "arm.json: keyframe 1 ('up'): unknown joint 'LElbow' (not a joint of this robot)"
    # fixing the file in place is picked up on the next goal
    write(animations, "broken.json", {"name": "broken", "keyframes": [{"goals": {"LKnee": 10}, "duration": 0.1}]})
    goal = body.play("broken")
    assert goal.wait_accepted(10.0), goal.reason
    assert goal.wait_result(10.0)[0] == GoalStatus.SUCCEEDED


def test_real_stand_up_front_ends_at_last_keyframe(bus: BusConfig, body: Body, testdata: Path,
                                                   tmp_path: Path) -> None:
    source = testdata / "animations" / "wolfgang_stand_up_front.json"
    raw = json.loads(source.read_text())
    body.positions = dict.fromkeys(raw["keyframes"][0]["goals"], 0.0)
    node = AnimationNode(bus=bus, overrides={"animation_dir": str(tmp_path / "missing"),
                                             "search_path": str(testdata / "animations")})
    node.start()
    try:
        wait_for(lambda: node.joint_positions is not None and "RKnee" in node.joint_positions, 10.0)
        goal = body.play("Standup Front", hcm=True)
        assert goal.wait_accepted(10.0), goal.reason
        status, result = goal.wait_result(20.0)
        assert status == GoalStatus.SUCCEEDED and result.successful
        last = wait_for(lambda: [m for m in list(body.received) if m.last], 10.0)[-1]
        names = list(last.position.joint_names)
        assert sorted(names) == sorted(raw["keyframes"][-1]["goals"])
        expected = [math.radians(raw["keyframes"][-1]["goals"][j]) for j in names]
        assert np.allclose(last.position.points[0].positions, expected)
        assert last.hcm
        by_file = body.play("wolfgang_stand_up_front")  # also found by its file name
        assert by_file.wait_accepted(10.0), by_file.reason
        assert by_file.cancel(10.0)
    finally:
        node.shutdown()


def test_without_joint_states_starts_from_first_keyframe(bus: BusConfig, animations: Path) -> None:
    node = AnimationNode(robot_id="robot2", bus=bus,
                         overrides={"animation_dir": str(animations), "joint_states_wait_s": 0.3})
    listener = Body(robot_id="robot2", bus=bus)  # publishes no joint_states
    node.start()
    listener.start()
    try:
        goal = listener.play("nod")
        assert goal.wait_accepted(10.0), goal.reason
        assert goal.wait_result(20.0)[0] == GoalStatus.SUCCEEDED
        steps = wait_for(lambda: [m for m in list(listener.received) if m.last] and list(listener.received), 10.0)
        assert steps[0].first
        assert list(steps[0].position.points[0].positions) == pytest.approx(
            [math.radians(-30.0), math.radians(15.0)], abs=1e-6)
    finally:
        listener.shutdown()
        node.shutdown()


def test_missing_default_folder_is_empty(bus: BusConfig) -> None:
    node = AnimationNode(bus=bus, overrides={"model": "no_such_robot"})
    try:
        assert node.folders()[0].parts[-3:] == ("robots", "no_such_robot", "animations")
        assert node.library.names() == []
        assert not node.library.problems
    finally:
        node.shutdown()


def test_runs_as_its_own_process(router_endpoint: str, body: Body, animations: Path) -> None:
    """``python -m robot_nodes.animation`` serves goals and stops cleanly on SIGTERM."""
    repo = Path(__file__).resolve().parents[1]
    proc = subprocess.Popen([sys.executable, "-m", "robot_nodes.animation", "--connect", router_endpoint,
                             "--set", f"animation_dir={animations}", "--log-level", "WARNING"],
                            cwd=repo, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        goal = body.play("knee_bend", timeout=30.0)  # asks again until the process serves the action
        assert goal.wait_accepted(35.0), goal.reason
        assert goal.wait_result(30.0)[0] == GoalStatus.SUCCEEDED
    finally:
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=20)
    assert proc.returncode == 0, err.decode()
