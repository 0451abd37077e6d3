"""The HCM's pure parts: fall checker, state machine table, joint mutex for every state."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robot_nodes.hcm.fall_checker import FallChecker, Side, fused_angles
from robot_nodes.hcm.joint_mutex import PASSES_IN, GoalSource, passes
from robot_nodes.hcm.state_machine import PROPPED_S, PUBLISHED_VALUE, Blackboard, HcmState, HcmStateMachine

S = HcmState


def quat_about(axis: str, angle: float) -> np.ndarray:
    s, c = math.sin(angle / 2), math.cos(angle / 2)
    return {"x": np.array([s, 0, 0, c]), "y": np.array([0, s, 0, c]), "z": np.array([0, 0, s, c])}[axis]


@pytest.mark.parametrize(("axis", "angle", "expect"), [
    ("y", 0.5, (0.0, 0.5)), ("y", -0.5, (0.0, -0.5)), ("x", 0.3, (0.3, 0.0)), ("z", 1.0, (0.0, 0.0)),
])
def test_fused_angles(axis: str, angle: float, expect: tuple[float, float]) -> None:
    assert fused_angles(quat_about(axis, angle)) == pytest.approx(expect, abs=1e-9)


def run_checker(axis: str, angle: float, gyro: float, steps: int = 20) -> FallChecker:
    checker = FallChecker()
    g = np.zeros(3)
    g["xyz".index(axis)] = gyro
    for i in range(steps):
        checker.update(i * 0.005, quat_about(axis, angle), g)
    return checker


def test_upright_and_still_is_stable() -> None:
    checker = run_checker("y", 0.02, 0.0)
    assert checker.falling is None and checker.fallen is None


@pytest.mark.parametrize(("axis", "sign", "side"), [
    ("y", 1, Side.FRONT), ("y", -1, Side.BACK), ("x", 1, Side.RIGHT), ("x", -1, Side.LEFT)])
def test_falling_direction(axis: str, sign: int, side: Side) -> None:
    assert run_checker(axis, sign * 0.6, sign * 3.0).falling is side


def test_fast_rotation_near_upright_is_falling_slow_is_not() -> None:
    assert run_checker("y", 0.1, 9.0).falling is Side.FRONT
    assert run_checker("y", 0.1, 1.0).falling is None


def test_rotating_back_to_upright_is_not_falling() -> None:
    assert run_checker("y", 0.3, -3.0).falling is None


def test_one_stable_reading_in_the_window_vetoes() -> None:
    checker = FallChecker()
    checker.update(0.0, quat_about("y", 0.0), np.zeros(3))
    checker.update(0.01, quat_about("y", 0.6), np.array([0, 3.0, 0]))
    assert checker.falling is None
    checker.update(0.06, quat_about("y", 0.7), np.array([0, 3.0, 0]))
    assert checker.falling is Side.FRONT


@pytest.mark.parametrize(("axis", "angle", "side"), [
    ("y", 1.5, Side.FRONT), ("y", -1.5, Side.BACK), ("x", 1.4, Side.RIGHT), ("x", -1.4, Side.LEFT)])
def test_lying_at_rest(axis: str, angle: float, side: Side) -> None:
    assert run_checker(axis, angle, 0.0, steps=60).fallen is side
    assert run_checker(axis, angle, 1.0, steps=60).fallen is None, "still moving: not yet lying"


@pytest.mark.parametrize(("axis", "angle", "side"), [
    ("y", 0.8, Side.FRONT), ("y", -0.8, Side.BACK), ("x", 0.7, Side.RIGHT), ("x", -0.7, Side.LEFT)])
def test_propped_up_is_not_lying_but_leans(axis: str, angle: float, side: Side) -> None:
    """45 deg, on another robot and shaken by it: not lying, but the side to stand up from is known."""
    checker = run_checker(axis, angle, 1.0, steps=60)
    assert checker.fallen is None and checker.leaning is side


class Recorder:
    def __init__(self) -> None:
        self.calls: list[tuple[str, object]] = []

    def play(self, animation: str) -> None:
        self.calls.append(("play", animation))

    def cancel_animation(self) -> None:
        self.calls.append(("cancel", None))

    def torque(self, enabled: bool) -> None:
        self.calls.append(("torque", enabled))

    def speak(self, text: str, priority: int) -> None:
        self.calls.append(("speak", text))


def started(bb: Blackboard) -> tuple[HcmStateMachine, Recorder]:
    actions = Recorder()
    machine = HcmStateMachine(actions=actions)
    bb.hardware_ok = True
    machine.step(bb)  # plays walkready
    assert ("play", "walkready") in actions.calls
    bb.animation_busy = False
    machine.step(bb)
    assert machine.state is S.CONTROLLABLE
    return machine, actions


def getting_up(side: Side) -> tuple[Blackboard, HcmStateMachine, Recorder]:
    """A started robot lying on ``side``, its stand-up just begun."""
    bb = Blackboard()
    machine, actions = started(bb)
    bb.fallen = side
    machine.step(bb)
    machine.step(bb)
    assert machine.state is S.GETTING_UP and actions.calls[-1] == ("play", f"stand_up_{side.value}")
    return bb, machine, actions


def test_startup_waits_for_hardware_then_walkready() -> None:
    actions = Recorder()
    machine = HcmStateMachine(actions=actions)
    bb = Blackboard()
    for _ in range(3):
        machine.step(bb)
    assert machine.state is S.STARTUP and not actions.calls
    started(Blackboard())


def test_fall_sequence_front() -> None:
    bb = Blackboard()
    machine, actions = started(bb)
    bb.falling = Side.FRONT
    machine.step(bb)
    assert machine.state is S.FALLING and actions.calls[-1] == ("play", "falling_front")
    bb.falling, bb.fallen, bb.animation_busy = None, Side.FRONT, False
    machine.step(bb)
    assert machine.state is S.FALLEN
    machine.step(bb)
    assert machine.state is S.GETTING_UP and actions.calls[-1] == ("play", "stand_up_front")
    bb.fallen, bb.animation_busy = None, False
    machine.step(bb)
    assert machine.state is S.GETTING_UP_SETTLE and PUBLISHED_VALUE[machine.state] == 3
    bb.animation_busy = False
    machine.step(bb)
    assert machine.state is S.CONTROLLABLE


def test_failed_stand_up_goes_back_to_fallen() -> None:
    bb, machine, _ = getting_up(Side.BACK)
    bb.animation_busy = False
    machine.step(bb)
    assert machine.state is S.FALLEN, "still lying after the stand-up animation"
    machine.step(bb)
    assert machine.state is S.GETTING_UP, "tries again"
    bb.fallen, bb.animation_busy = None, False  # up this time, but the settling walk-ready tips it over
    machine.step(bb)
    assert machine.state is S.GETTING_UP_SETTLE
    bb.fallen, bb.animation_busy = Side.BACK, False
    machine.step(bb)
    assert machine.state is S.FALLEN


def test_stand_up_that_ends_on_the_other_side_stands_up_from_there() -> None:
    bb, machine, actions = getting_up(Side.BACK)
    bb.fallen, bb.animation_busy = Side.FRONT, False  # stand_up_back rolled the robot onto its front
    machine.step(bb)
    assert machine.state is S.FALLEN and actions.calls[-1] != ("play", "walkready")
    machine.step(bb)
    assert machine.state is S.GETTING_UP and actions.calls[-1] == ("play", "stand_up_front")


def test_stand_up_that_ends_still_rolling_waits_until_the_robot_lies() -> None:
    bb, machine, actions = getting_up(Side.BACK)
    bb.fallen, bb.falling, bb.upright, bb.animation_busy = None, Side.FRONT, False, False  # rolling over
    machine.step(bb)
    assert machine.state is S.FALLEN, "waits lying, no walkready and no falling animation while still rolling"
    assert actions.calls[-1] == ("play", "stand_up_back")
    machine.step(bb)
    assert machine.state is S.FALLEN
    bb.fallen, bb.falling = Side.FRONT, None  # now lying on the front
    machine.step(bb)
    assert machine.state is S.GETTING_UP and actions.calls[-1] == ("play", "stand_up_front")


def test_stand_up_that_ends_tipping_for_good_tries_again_from_where_it_leans() -> None:
    """Entangled with a robot it lies on: shaken, never at rest, never upright. It does not wait in GETTING_UP for
    a rest that does not come (a match: 6.6 s), but tries again after PROPPED_S."""
    bb, machine, actions = getting_up(Side.FRONT)
    bb.fallen, bb.falling, bb.upright, bb.animation_busy, bb.leaning = None, Side.BACK, False, False, Side.FRONT
    machine.step(bb)
    assert machine.state is S.FALLEN
    bb.now += PROPPED_S + 0.1
    machine.step(bb)
    assert machine.state is S.GETTING_UP and actions.calls[-1] == ("play", "stand_up_front")


def test_penalty_from_walking_lets_the_walk_stop_first() -> None:
    bb = Blackboard()
    machine, actions = started(bb)
    bb.walking_active = True
    machine.step(bb)
    assert machine.state is S.WALKING
    bb.penalized = True
    machine.step(bb)
    assert machine.state is S.WALKING_STOPPING and PUBLISHED_VALUE[machine.state] == 10
    machine.step(bb)
    assert machine.state is S.WALKING_STOPPING
    bb.walking_active = False
    machine.step(bb)
    assert machine.state is S.PENALTY_ANIMATION_IN and ("play", "penalty_in") in actions.calls
    bb.animation_busy = False
    machine.step(bb)
    assert machine.state is S.PENALTY and actions.calls[-1] == ("torque", False)
    bb.penalized = False
    machine.step(bb)
    assert machine.state is S.PENALTY_ANIMATION_OUT and ("torque", True) in actions.calls
    bb.animation_busy = False
    machine.step(bb)
    assert machine.state is S.CONTROLLABLE


def test_a_penalty_cuts_a_stand_up_short() -> None:
    """Penalised while getting up (the referee calls a robot that lay too long): the stand-up stops and the penalty
    animation plays at once, not after the stand-up; the same while settling lying after it. Standing while
    settling, the robot settles first."""
    for settling, upright in ((False, False), (True, False), (True, True)):
        bb, machine, actions = getting_up(Side.FRONT)
        if settling:
            bb.fallen, bb.animation_busy, bb.upright = None, False, upright
            machine.step(bb)
            assert machine.state is S.GETTING_UP_SETTLE
        bb.animation_busy = True  # the stand-up (or the settling walk-ready) still playing
        bb.penalized = True
        machine.step(bb)
        if upright:
            assert machine.state is S.GETTING_UP_SETTLE  # on its feet: walk-ready ends, then the penalty
            bb.animation_busy = False
            machine.step(bb)
            assert machine.state is S.CONTROLLABLE
            machine.step(bb)
        else:
            assert machine.state is S.FALLEN and actions.calls[-1] == ("cancel", None)
            assert not bb.animation_busy
            machine.step(bb)
        assert machine.state is S.PENALTY_ANIMATION_IN and actions.calls[-1] == ("play", "penalty_in")


def test_a_robot_propped_up_gets_up_from_where_it_leans() -> None:
    """Fallen onto another robot: neither lying (60 deg at rest) nor upright. After PROPPED_S in FALLEN it stands up
    from the side it leans to, or turns onto its front from a side, instead of waiting for the referee."""
    for leaning, first in ((Side.BACK, ("play", "stand_up_back")), (Side.LEFT, ("play", "turning_front"))):
        bb = Blackboard()
        machine, actions = started(bb)
        bb.falling = Side.FRONT
        machine.step(bb)
        bb.falling, bb.animation_busy, bb.upright, bb.leaning = None, False, False, leaning
        bb.fallen = Side.FRONT  # lay for a moment, then slid onto the other robot
        machine.step(bb)
        assert machine.state is S.FALLEN
        bb.fallen = None
        bb.now += PROPPED_S - 0.1
        machine.step(bb)
        assert machine.state is S.FALLEN and actions.calls[-1] != first  # may still be sliding: it waits
        bb.now += 0.2
        machine.step(bb)
        assert actions.calls[-1] == first
        assert machine.state is (S.GETTING_UP if leaning is Side.BACK else S.FALLEN)


def test_hardware_problem_and_recovery() -> None:
    bb = Blackboard()
    machine, _ = started(bb)
    bb.hardware_ok = False
    machine.step(bb)
    assert machine.state is S.HARDWARE_PROBLEM
    bb.hardware_ok = True
    machine.step(bb)
    assert machine.state is S.STARTUP


def test_motor_off_after_inactivity_and_wake_up() -> None:
    bb = Blackboard(motor_off_after_s=10.0)
    machine, actions = started(bb)
    bb.idle_s = 11.0
    machine.step(bb)
    assert machine.state is S.MOTOR_OFF and actions.calls[-1] == ("torque", False)
    bb.motion_requested = True
    machine.step(bb)
    assert machine.state is S.STARTUP


def test_shutdown_then_off() -> None:
    bb = Blackboard()
    machine, actions = started(bb)
    bb.shutdown = True
    machine.step(bb)
    assert machine.state is S.SHUTDOWN and actions.calls[-1] == ("play", "shutdown")
    bb.animation_busy = False
    machine.step(bb)
    assert machine.state is S.HCM_OFF and actions.calls[-1] == ("torque", False)


def test_every_state_is_reachable_and_has_a_published_value() -> None:
    machine = HcmStateMachine(actions=Recorder())
    states, transitions = machine.graph()
    targets = {t[1] for t in transitions}
    assert set(states) - targets == {"STARTUP"} or set(states) - targets == set()
    assert set(PUBLISHED_VALUE) == set(HcmState)
    assert all(condition for _, _, condition in transitions)


EXPECTED_PASS = {
    GoalSource.WALKING: {S.CONTROLLABLE, S.WALKING, S.WALKING_STOPPING},
    GoalSource.HEAD: {S.CONTROLLABLE, S.WALKING, S.WALKING_STOPPING},
    GoalSource.ANIMATION: {S.ANIMATION_RUNNING},
    GoalSource.RECORD: {S.RECORD},
}


@pytest.mark.parametrize("state", list(HcmState))
def test_joint_mutex_for_every_state(state: HcmState) -> None:
    for source, allowed in EXPECTED_PASS.items():
        assert passes(source, state) == (state in allowed), (source, state)
    if state is S.RECORD:
        assert [s for s in GoalSource if passes(s, state)] == [GoalSource.RECORD], "in RECORD only the recorder"
    if state is S.ANIMATION_RUNNING:
        assert not passes(GoalSource.WALKING, state)
    assert PASSES_IN[GoalSource.HCM_ANIMATION] >= {S.FALLING, S.GETTING_UP, S.STARTUP}
