"""The HCM with the real nodes on a simulated robot: start-up, falls, penalties, joint mutex, hardware problems."""

from __future__ import annotations

import dataclasses
import json
import math
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import zenoh

import schemas
from robot_nodes.animation.node import AnimationNode
from robot_nodes.cm730.backend import BusReading
from robot_nodes.cm730.node import Cm730Node
from robot_nodes.hcm.node import HcmNode
from robot_nodes.hcm.pause import PauseNode
from robot_nodes.runtime import BusConfig, ParameterClient, call_service, open_session
from robot_nodes.runtime.clock import CLOCK_PERIOD_S, SimClock
from tests.sim_robots import MINIBOT_HCM, pass_time
from tests.support import REPO
from tests.waiting import wait_for
from wire.actions import ActionClient, GoalStatus
from wire.keys import topic_key

pytestmark = [pytest.mark.realtime, pytest.mark.slow]

CONTROLLABLE, FALLING, FALLEN, GETTING_UP, ANIMATION_RUNNING, STARTUP = 0, 1, 2, 3, 4, 5
PENALTY, PENALTY_ANIMATION, RECORD, HARDWARE_PROBLEM = 7, 8, 9, 13
UPRIGHT = 0.9  # torso up-axis z
STANDING_HEIGHT = 0.30  # m, base_link above the ground (walkready stands at about 0.355)
GROUND_HEIGHT = 0.15  # m, below this the torso has hit (or is about to hit) the ground
CM730 = {"publish_rate": 100.0, "render_camera": False, "camera_rate": 0.1, "ground_truth_rate": 1.0}
# four nodes and MuJoCo share this process and a loaded 2-core machine: a 0.5 s gap in joint_states is no servo
# failure here, so only the hardware test keeps the 0.5 s timeouts of the real robot
PATIENT_HCM = {"imu_timeout_s": 2.0, "motor_timeout_s": 2.0}


class Stack:
    """cm730 (MuJoCo), animation, HCM and pause nodes in this process (composed on one session, or a session each),
    plus a client session that watches. The nodes follow the world's clock in lockstep (tests/sim_robots.py says
    why), and every time the test takes or judges is the world's simulated time (``now``)."""

    def __init__(self, bus: BusConfig, robot_bus: BusConfig | zenoh.Session, hcm: dict[str, Any] | None = None,
                 animation: dict[str, Any] | None = None, yaw: float = 0.0) -> None:
        self.clock = SimClock(lockstep=True)
        self.cm730 = Cm730Node(bus=robot_bus, overrides=CM730, clock=self.clock)
        self.robot = self.cm730.backend.robot  # type: ignore[attr-defined]
        self.world = self.cm730.backend.world  # type: ignore[attr-defined]
        with self.world.lock:
            self.world.set_ball(3.0, 3.0)  # the kick-off ball must not prop up a robot lying at the centre
            x, y, _ = self.robot.pose2d()
            self.robot.set_pose(x, y, yaw)
        self.session = open_session(bus)
        self.lock = threading.Lock()
        self.states: list[tuple[float, int]] = []  # (arrival, state) of every robot_state message
        self.animation_msgs: list[tuple[float, Any]] = []
        self.motor_goals: list[tuple[float, Any]] = []
        self.heights: list[tuple[float, float]] = []
        self._subs = [
            self._listen("robot_state", self.states, lambda m: int(m.state)),
            self._listen("animation", self.animation_msgs, lambda m: m),
            self._listen("motor_goals", self.motor_goals, lambda m: m),
        ]
        runner = self.cm730.backend.runner  # type: ignore[attr-defined]
        runner.every(0.005, self._sample_height)  # 5 ms resolution is plenty against a fall of about a second
        runner.tick_clock(CLOCK_PERIOD_S, self.clock.advance)
        self.nodes = [self.cm730.start(),
                      AnimationNode(bus=robot_bus, overrides=animation or {}, clock=self.clock).start(),
                      HcmNode(bus=robot_bus, overrides={**PATIENT_HCM, **(hcm or {})}, clock=self.clock).start(),
                      PauseNode(bus=robot_bus, clock=self.clock).start()]
        self.hcm: HcmNode = self.nodes[2]  # type: ignore[assignment]
        self.animation: AnimationNode = self.nodes[1]  # type: ignore[assignment]
        self.actions = ActionClient(self.session, "robot1", "animation")

    def _listen(self, topic: str, into: list[tuple[float, Any]], pick: Callable[[Any], Any]) -> Any:
        typename = schemas.topic(topic).type

        def on_sample(sample: zenoh.Sample) -> None:
            msg = schemas.decode(sample.payload.to_bytes(), typename)
            with self.lock:
                into.append((self.now(), pick(msg)))

        return self.session.declare_subscriber(topic_key("robot1", topic), on_sample)

    def _sample_height(self) -> None:
        """On the physics thread, holding the world's lock."""
        z = float(self.robot.torso_pose()[0][2])
        with self.lock:
            self.heights.append((self.world.time, z))

    # -- what the test looks at --------------------------------------------------------------------------
    def now(self) -> float:
        """The world's simulated seconds, the nodes' time."""
        return self.clock.now()

    def pass_time(self, seconds: float) -> None:
        pass_time(self.clock, seconds)

    def state(self) -> int | None:
        with self.lock:
            return self.states[-1][1] if self.states else None

    def sequence(self, since: float = 0.0) -> list[int]:
        """The states published since ``since``, repeats collapsed."""
        with self.lock:
            out: list[int] = []
            for t, s in self.states:
                if t >= since and (not out or out[-1] != s):
                    out.append(s)
            return out

    def first_time(self, state: int, since: float) -> float | None:
        with self.lock:
            return next((t for t, s in self.states if t >= since and s == state), None)

    def standing(self) -> bool:
        with self.world.lock:
            return self.robot.uprightness() > UPRIGHT and float(self.robot.torso_pose()[0][2]) > STANDING_HEIGHT

    def wait(self, condition: Callable[[], Any], timeout: float, what: str, since: float = 0.0) -> Any:
        """wait_for, but a timeout reports the states published since ``since`` as they are then."""
        try:
            return wait_for(condition, timeout, what=what)
        except AssertionError as exc:
            raise AssertionError(f"{exc}; states seen {self.sequence(since)}, HCM in {self.hcm.machine.state}, "
                                 f"{'standing' if self.standing() else 'not standing'}") from None

    def wait_state(self, state: int, timeout: float, what: str = "") -> float:
        self.wait(lambda: self.state() == state, timeout, what or f"state {state}")
        return self.now()

    def wait_controllable_standing(self, timeout: float = 30.0, since: float = 0.0) -> None:
        self.wait(lambda: self.state() == CONTROLLABLE and self.standing(), timeout, "CONTROLLABLE and standing",
                  since)

    def publisher(self, topic: str) -> Any:
        return self.session.declare_publisher(topic_key("robot1", topic))

    def close(self) -> None:
        for node in reversed(self.nodes):
            node.shutdown()
        self.actions.close()
        for sub in self._subs:
            sub.undeclare()
        self.session.close()


@pytest.fixture
def make_stack(bus: BusConfig, robot_bus: BusConfig | zenoh.Session) -> Iterator[Callable[..., Stack]]:
    """The robot's nodes composed in one session, and split into a session each (the test runs in both)."""
    stacks: list[Stack] = []

    def make(**kwargs: Any) -> Stack:
        stacks.append(Stack(bus, robot_bus, **kwargs))
        return stacks[-1]

    yield make
    for stack in stacks:
        stack.close()


def trajectory(names: list[str], positions: list[float]) -> Any:
    point = schemas.make("trajectory_msgs/msg/JointTrajectoryPoint", positions=np.array(positions, dtype=float))
    return schemas.make("trajectory_msgs/msg/JointTrajectory", joint_names=names, points=[point])


def test_startup_goes_to_controllable_standing(make_stack: Callable[..., Stack]) -> None:
    stack = make_stack()
    stack.wait_controllable_standing()
    seq = stack.sequence()
    assert seq[0] == STARTUP and seq[-1] == CONTROLLABLE, seq
    assert set(seq) <= {STARTUP, CONTROLLABLE}, seq
    with stack.world.lock:
        assert stack.robot.uprightness() > UPRIGHT


@pytest.mark.parametrize(("direction", "yaw"), [("front", 0.8), ("back", -2.2)])
def test_pushed_over_falls_protected_and_gets_up(make_stack: Callable[..., Stack], direction: str,
                                                 yaw: float) -> None:
    stack = make_stack(yaw=yaw)
    stack.wait_controllable_standing()
    stack.pass_time(0.5)  # a moment of quiet stance before the push
    sign = 1.0 if direction == "front" else -1.0
    pushed = stack.now()
    with stack.world.lock:
        _, _, heading = stack.robot.pose2d()
        stack.robot.apply_push((sign * 60.0 * math.cos(heading), sign * 60.0 * math.sin(heading), 0.0), 0.15)

    def on_the_ground() -> float | None:
        with stack.lock:
            return next((t for t, z in stack.heights if t > pushed and z < GROUND_HEIGHT), None)

    hit = wait_for(on_the_ground, 10.0, what="the torso on the ground")
    stack.wait(lambda: stack.first_time(GETTING_UP, pushed) is not None, 15.0, "GETTING_UP", pushed)
    stack.wait_controllable_standing(20.0, pushed)
    up = stack.now()
    seq = stack.sequence(pushed)
    while seq and seq[0] == CONTROLLABLE:  # robot_state of before the push, still on its way
        seq.pop(0)
    # from the back the robot first rolls onto its front (a second FALLEN -> GETTING_UP); a stand-up that
    # fails is tried again, within the time limit
    assert seq[:3] == [FALLING, FALLEN, GETTING_UP] and seq[-1] == CONTROLLABLE, seq
    assert set(seq) == {FALLING, FALLEN, GETTING_UP, CONTROLLABLE}, seq
    # the 15 s (about 4.4 s front, 7.5 s back, where the robot first rolls onto its front)
    assert up - pushed < 15.0, f"standing {up - pushed:.1f} s after the push"
    falling = stack.first_time(FALLING, pushed)
    with stack.lock:
        protect = next(t for t, m in stack.animation_msgs
                       if t > pushed and m.hcm and m.first and list(m.position.joint_names))
    assert falling is not None and falling < hit, "FALLING only after the torso hit the ground"
    assert protect < hit, "the falling animation started only after the torso hit the ground"
    print(f"\n{direction}: FALLING {hit - falling:.3f} s and falling animation {hit - protect:.3f} s before "
          f"the torso was below {GROUND_HEIGHT} m; standing {up - pushed:.1f} s after the push; states {seq}; "
          f"goals clamped into the joint-limit margin: {stack.cm730.clamps.by_joint() or 'none'}, worst "
          f"{stack.cm730.clamps.worst() or '-'}")


@pytest.mark.parametrize("side", ["left", "right"])
def test_lying_on_a_side_turns_onto_the_front_and_gets_up(make_stack: Callable[..., Stack], side: str) -> None:
    """No stand-up starts from a side: the Minibot's params.yaml names the animation that tips it over first
    (walk-ready, the Bit-Bots default, leaves the Minibot lying on its side for good)."""
    stack = make_stack(hcm=MINIBOT_HCM)
    stack.wait_controllable_standing()
    laid = stack.now()
    with stack.world.lock:
        x, y, yaw = stack.robot.pose2d()
        stack.robot.set_pose(x, y, yaw, posture=side)
    stack.wait(lambda: stack.first_time(GETTING_UP, laid) is not None, 15.0, "GETTING_UP", laid)
    stack.wait_controllable_standing(25.0, laid)
    up = stack.now()
    seq = stack.sequence(laid)
    assert FALLEN in seq and GETTING_UP in seq and seq[-1] == CONTROLLABLE, seq
    assert up - laid < 20.0, f"standing {up - laid:.1f} s after it was laid on its {side}"  # the referee's 20 s
    print(f"\n{side}: standing {up - laid:.1f} s after it was laid on its side; states {seq}")


def _penalty_round(stack: Stack, penalize: Callable[[bool], None], torque_off: bool) -> None:
    stack.wait_controllable_standing()
    asked = stack.now()
    penalize(True)
    stack.wait(lambda: stack.first_time(PENALTY, asked) is not None, 5.0, "PENALTY", asked)
    first = stack.first_time(PENALTY_ANIMATION, asked) or stack.first_time(PENALTY, asked)
    reached = stack.first_time(PENALTY, asked)
    assert first is not None and reached is not None
    # the 0.5 s: the HCM is in its penalty states (the penalty-in animation first) within 0.5 s; the
    # settled PENALTY comes when that animation ends (about 0.35 s when idle; the limit leaves room for load)
    assert first - asked < 0.5, f"first penalty state {first - asked:.3f} s after the request"
    assert reached - asked < 1.5, f"PENALTY {reached - asked:.3f} s after the request"
    print(f"\npenalty animation {first - asked:.3f} s, PENALTY {reached - asked:.3f} s after the request")
    with stack.world.lock:
        enabled = stack.robot.torque_enabled.copy()
    wait_for(lambda: not stack.robot.torque_enabled.any() if torque_off else stack.robot.torque_enabled.all(), 2.0,
             what=f"torque {'off' if torque_off else 'on'} in PENALTY (was {enabled})")
    stack.pass_time(0.3)
    assert stack.state() == PENALTY
    freed = stack.now()
    penalize(False)
    stack.wait_controllable_standing(25.0, freed)
    assert stack.robot.torque_enabled.all()


def test_manual_penalize_service(make_stack: Callable[..., Stack]) -> None:
    stack = make_stack(hcm={"penalty_torque_off": False})
    request = "humanoid_league_msgs/srv/ManualPenalize_Request"
    consts = schemas.constants(request)

    def penalize(on: bool) -> None:
        reply = call_service(stack.session, "robot1", "manual_penalize",
                             schemas.make(request, penalize=consts["ON" if on else "OFF"]))
        assert reply.penalized == on

    _penalty_round(stack, penalize, torque_off=False)


def test_gamecontroller_penalty(make_stack: Callable[..., Stack]) -> None:
    stack = make_stack(hcm={"penalty_torque_off": True})
    gamestate = stack.publisher("gamestate")
    penalized = threading.Event()
    stop = threading.Event()

    def game_controller() -> None:  # like the receiver: a GameState twice a second, at once on a change
        while not stop.is_set():
            gamestate.put(schemas.encode(schemas.make("humanoid_league_msgs/msg/GameState", game_state=3,
                                                      penalized=penalized.is_set(),
                                                      allowed_to_move=not penalized.is_set())))
            stop.wait(0.5)

    sender = threading.Thread(target=game_controller, daemon=True)
    sender.start()

    def penalize(on: bool) -> None:
        penalized.set() if on else penalized.clear()
        gamestate.put(schemas.encode(schemas.make("humanoid_league_msgs/msg/GameState", game_state=3,
                                                  penalized=on, allowed_to_move=not on)))

    try:
        _penalty_round(stack, penalize, torque_off=True)
    finally:
        stop.set()
        sender.join(2.0)
        gamestate.undeclare()


def test_joint_mutex_animation_and_record(make_stack: Callable[..., Stack]) -> None:
    stack = make_stack()
    stack.wait_controllable_standing()
    walk = stack.publisher("walk_motor_goals")
    record = stack.publisher("record_motor_goals")
    walk_marker, record_marker = 0.4321, -0.1234

    def marked(value: float, since: float) -> list[float]:
        with stack.lock:
            return [t for t, m in stack.motor_goals if t >= since and list(m.joint_names) == ["HeadPan"]
                    and m.points and abs(m.points[0].positions[0] - value) < 1e-9]

    # walking goals pass while CONTROLLABLE (the check that the marker can be seen at all)
    start = stack.now()
    wait_for(lambda: walk.put(schemas.encode(trajectory(["HeadPan"], [walk_marker]))) or marked(walk_marker, start),
             5.0, what="walk goals forwarded while CONTROLLABLE")
    wait_for(lambda: stack.state() == CONTROLLABLE, 5.0, what="back to CONTROLLABLE after the walk goals")

    goal = stack.actions.send_goal(schemas.make("humanoid_league_msgs/action/PlayAnimation_Goal",
                                                animation="init", hcm=False))
    assert goal.wait_accepted(10.0), goal.reason
    running = stack.wait_state(ANIMATION_RUNNING, 5.0)
    sent = 0
    while stack.state() == ANIMATION_RUNNING and stack.now() - running < 1.5:
        walk.put(schemas.encode(trajectory(["HeadPan"], [walk_marker])))
        sent += 1
        time.sleep(0.02)
    assert sent > 20 and stack.state() == ANIMATION_RUNNING
    assert not marked(walk_marker, running + 0.05), "walking goals reached motor_goals during ANIMATION_RUNNING"
    with stack.lock:
        from_animation = [m for t, m in stack.motor_goals if t >= running and "LKnee" in list(m.joint_names)]
    assert from_animation, "the animation's own goals reach motor_goals"
    assert goal.wait_result(10.0)[0] == GoalStatus.SUCCEEDED
    stack.wait_state(CONTROLLABLE, 5.0)

    # a canceled external animation ends with a last=True message without joints: the HCM need not time out
    goal = stack.actions.send_goal(schemas.make("humanoid_league_msgs/action/PlayAnimation_Goal",
                                                animation="init", hcm=False))
    assert goal.wait_accepted(10.0), goal.reason
    stack.wait_state(ANIMATION_RUNNING, 5.0)
    canceled = stack.now()
    assert goal.cancel(5.0)
    with_last = wait_for(lambda: [t for t, m in list(stack.animation_msgs)
                                  if t >= canceled and m.last and not m.hcm and not list(m.position.joint_names)],
                         5.0, what="the last=True message of the canceled animation")
    stack.wait_state(CONTROLLABLE, 5.0)
    print(f"\ncanceled animation: CONTROLLABLE {stack.first_time(CONTROLLABLE, canceled) - canceled:.3f} s after "
          f"the cancel ({with_last[0] - canceled:.3f} s to its last message)")

    params = ParameterClient(stack.session, "robot1")
    params.set("hcm", {"record_mode": True})
    recording = stack.wait_state(RECORD, 5.0)
    end = recording + 1.0
    while stack.now() < end:
        walk.put(schemas.encode(trajectory(["HeadPan"], [walk_marker])))
        record.put(schemas.encode(trajectory(["HeadPan"], [record_marker])))
        time.sleep(0.02)
    assert stack.state() == RECORD
    assert marked(record_marker, recording), "record goals did not reach motor_goals in RECORD"
    assert not marked(walk_marker, recording + 0.05), "walking goals reached motor_goals in RECORD"
    params.set("hcm", {"record_mode": False})
    stack.wait_controllable_standing(15.0)


def test_real_bitbots_animation_plays_to_the_end(make_stack: Callable[..., Stack], testdata: Path) -> None:
    folder = testdata / "animations"
    # the straight-legged init pose leans forward: fall handling off, so nothing but the animation moves the joints
    stack = make_stack(animation={"search_path": str(folder)}, hcm={"fall_detection": False, "stand_up": False})
    stack.wait_controllable_standing()
    data = json.loads((folder / "wolfgang_init.json").read_text())
    final = data["keyframes"][-1]["goals"]
    goal = stack.actions.send_goal(schemas.make("humanoid_league_msgs/action/PlayAnimation_Goal",
                                                animation="wolfgang_init", hcm=False))
    assert goal.wait_accepted(10.0), goal.reason
    status, result = goal.wait_result(30.0)
    assert status == GoalStatus.SUCCEEDED and result.successful, result
    robot = stack.robot
    names = list(robot.joint_names)
    want = np.array([math.radians(final[n]) for n in names])
    reachable = np.clip(want, robot.lower, robot.upper)

    def last_sent_deg() -> float:  # how far the newest whole-body motor_goals are from the last keyframe
        with stack.lock:
            last = next(m for _, m in reversed(stack.motor_goals) if len(m.joint_names) == len(names))
        sent = dict(zip(last.joint_names, last.points[0].positions, strict=True))
        return float(np.degrees(np.abs(np.array([sent[n] for n in names]) - want)).max())

    # the animation's last step reaches the servos (two hops, after the result's one): exactly the last keyframe
    wait_for(lambda: last_sent_deg() < 0.01, 3.0, what="the last keyframe in motor_goals")

    def error_deg() -> np.ndarray:  # the figure: every joint within 2 degrees of the last keyframe
        with stack.world.lock:
            reading = robot.read()
        return np.degrees(np.abs(reading.positions - reachable))

    try:
        wait_for(lambda: bool(np.all(error_deg() < 2.0)), 3.0, what="every joint at the last keyframe")
    except AssertionError:
        raise AssertionError({n: round(float(e), 2) for n, e in zip(names, error_deg(), strict=True)
                              if e >= 2.0}) from None
    print(f"\nwolfgang_init: every joint within {error_deg().max():.2f} deg of the last keyframe; "
          f"{int(np.sum(want != reachable))} goals clipped to joint limits")


def _break_bus(stack: Stack, fault: Callable[[BusReading], BusReading]) -> Callable[[], None]:
    """A fault at the hardware edge: the backend's reads come back damaged until the returned undo is called."""
    backend = stack.cm730.backend
    original = backend.read
    backend.read = lambda: fault(original())  # type: ignore[method-assign]
    return lambda: setattr(backend, "read", original)


@pytest.mark.parametrize("fault", ["imu", "servo"])
def test_silent_hardware_is_a_hardware_problem(make_stack: Callable[..., Stack], fault: str) -> None:
    stack = make_stack(hcm={"imu_timeout_s": 0.5, "motor_timeout_s": 0.5})
    stack.wait_controllable_standing()
    if fault == "imu":
        undo = _break_bus(stack, lambda r: dataclasses.replace(r, imu=None))
    else:
        undo = _break_bus(stack, lambda r: dataclasses.replace(r, missing=["LKnee"]))
    broken = stack.now()
    try:
        problem = stack.wait_state(HARDWARE_PROBLEM, 5.0)
    finally:
        undo()
    back = stack.now()
    assert problem - broken < 1.0, f"HARDWARE_PROBLEM {problem - broken:.2f} s after the {fault} fell silent"
    stack.wait_controllable_standing(15.0)
    assert STARTUP in stack.sequence(back), stack.sequence(back)
    print(f"\n{fault}: HARDWARE_PROBLEM {problem - broken:.3f} s after it fell silent; "
          f"CONTROLLABLE {stack.now() - back:.1f} s after it returned")


def test_an_animation_with_torque_switches_reaches_the_servos_as_published(make_stack: Callable[..., Stack],
                                                                          tmp_path: Path) -> None:
    """The HCM passes an animation's torque switches on as motor_torque and its goals as motor_goals without
    changing the animation's message (composed, the animation node and telemetry share that very object)."""
    source = json.loads((REPO / "robots" / "minibot" / "animations" / "init.json").read_text())
    pose = source["keyframes"][0]["goals"]
    # limp from the end of the first keyframe's pause (1.5 s) to the end of the second (2.0 s)
    source["keyframes"] = [{"duration": 1.0, "pause": 0.5, "goals": pose, "torque": {"HeadPan": 0.0}},
                           {"duration": 0.5, "pause": 0.0, "goals": pose, "torque": {"HeadPan": 1.0}}]
    source["name"] = "limp_head"
    (tmp_path / "limp_head.json").write_text(json.dumps(source))
    stack = make_stack(animation={"search_path": str(tmp_path)})
    stack.wait_controllable_standing()
    head = stack.robot.joint_names.index("HeadPan")
    off: list[bool] = []
    goal = stack.actions.send_goal(schemas.make("humanoid_league_msgs/action/PlayAnimation_Goal",
                                                animation="limp_head", hcm=False))
    assert goal.wait_accepted(10.0), goal.reason
    def finished() -> bool:
        off.append(not stack.robot.torque_enabled[head])
        return goal.done

    stack.wait(finished, 30.0, "the animation played to its end")
    status, _ = goal.wait_result(1.0)
    assert any(off), "HeadPan went limp while the animation ran"
    # the goal's result and the last torque switch take different ways (action reply; HCM -> servos): both come
    stack.wait(lambda: bool(stack.robot.torque_enabled[head]), 5.0, "HeadPan stiff again at the animation's end")
    assert status == GoalStatus.SUCCEEDED
