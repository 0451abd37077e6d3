"""The HCM state machine (thesis ch. 5.2): states with entry/exit actions and transitions as data.

Transitions are a table of (source, target, condition text, test); ``step`` takes the first whose test holds.
Because the table is data, the graph the dashboard draws comes from the very code that decides.
"""

from __future__ import annotations

import enum
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

from robot_nodes.hcm.fall_checker import Side


class HcmState(enum.Enum):
    STARTUP = "STARTUP"
    CONTROLLABLE = "CONTROLLABLE"
    WALKING = "WALKING"
    WALKING_STOPPING = "WALKING_STOPPING"
    ANIMATION_RUNNING = "ANIMATION_RUNNING"
    FALLING = "FALLING"
    FALLEN = "FALLEN"
    GETTING_UP = "GETTING_UP"
    GETTING_UP_SETTLE = "GETTING_UP_SETTLE"
    PENALTY_ANIMATION_IN = "PENALTY_ANIMATION_IN"
    PENALTY = "PENALTY"
    PENALTY_ANIMATION_OUT = "PENALTY_ANIMATION_OUT"
    RECORD = "RECORD"
    MOTOR_OFF = "MOTOR_OFF"
    HARDWARE_PROBLEM = "HARDWARE_PROBLEM"
    SHUTDOWN = "SHUTDOWN"
    HCM_OFF = "HCM_OFF"


# the value each state publishes in RobotControlState (sub-states publish their parent's value)
PUBLISHED_VALUE: dict[HcmState, int] = {
    HcmState.CONTROLLABLE: 0, HcmState.FALLING: 1, HcmState.FALLEN: 2, HcmState.GETTING_UP: 3,
    HcmState.GETTING_UP_SETTLE: 3, HcmState.ANIMATION_RUNNING: 4, HcmState.STARTUP: 5, HcmState.SHUTDOWN: 6,
    HcmState.PENALTY: 7, HcmState.PENALTY_ANIMATION_IN: 8, HcmState.PENALTY_ANIMATION_OUT: 8,
    HcmState.RECORD: 9, HcmState.WALKING: 10, HcmState.WALKING_STOPPING: 10, HcmState.MOTOR_OFF: 11,
    HcmState.HCM_OFF: 12, HcmState.HARDWARE_PROBLEM: 13,
}


@dataclass
class Blackboard:
    """Everything the transitions look at, refreshed by the node before every step."""

    now: float = 0.0
    hardware_ok: bool = False
    falling: Side | None = None
    fallen: Side | None = None
    leaning: Side = Side.FRONT  # the side of the largest tilt (FallChecker.leaning)
    upright: bool = True
    penalized: bool = False
    record: bool = False
    shutdown: bool = False
    walking_active: bool = False
    external_animation: bool = False
    motion_requested: bool = False
    idle_s: float = 0.0
    animation_busy: bool = False  # an animation the HCM asked for is still playing
    startup_done: bool = False
    fall_detection: bool = True
    stand_up: bool = True
    motor_off_after_s: float = 0.0  # 0: never switch the motors off for inactivity
    walking_stop_timeout_s: float = 3.0
    shutdown_timeout_s: float = 5.0
    entered_at: float = 0.0


class HcmActions(Protocol):
    """What the states do to the robot; the node implements it."""

    def play(self, animation: str) -> None: ...
    def cancel_animation(self) -> None: ...
    def torque(self, enabled: bool) -> None: ...
    def speak(self, text: str, priority: int) -> None: ...


@dataclass(frozen=True)
class Transition:
    source: HcmState
    target: HcmState
    condition: str
    test: Callable[[Blackboard], bool]


S = HcmState


def _since_entry(bb: Blackboard) -> float:
    return bb.now - bb.entered_at


PROPPED_S = 2.0  # in FALLEN neither lying nor upright this long: propped up on something, get up from the tilt


def _propped(bb: Blackboard) -> bool:
    """Neither lying (fallen needs 60 deg of tilt at rest) nor upright, for PROPPED_S in FALLEN: on another robot or
    a post, or shaken by one. A match showed a robot propped on another for 7.6 s, trying nothing, until the
    referee took it off."""
    return bb.fallen is None and not bb.upright and _since_entry(bb) > PROPPED_S


def _lying_on(bb: Blackboard) -> Side | None:
    """The side to get up from in FALLEN: where it lies, or where it leans when propped."""
    return bb.fallen if bb.fallen is not None else bb.leaning if _propped(bb) else None


def _t(source: HcmState, target: HcmState, condition: str, test: Callable[[Blackboard], bool]) -> Transition:
    return Transition(source, target, condition, test)


def _common(source: HcmState, *, record: bool = True, penalty: bool = True, falls: bool = True) -> list[Transition]:
    """The checks every active state makes first, in the priority order of the Bit-Bots HCM."""
    out = [
        _t(source, S.SHUTDOWN, "shutdown requested", lambda bb: bb.shutdown),
        _t(source, S.HARDWARE_PROBLEM, "servos or IMU silent", lambda bb: not bb.hardware_ok),
    ]
    if record:
        out.append(_t(source, S.RECORD, "record mode on", lambda bb: bb.record))
    if penalty:
        target = S.WALKING_STOPPING if source == S.WALKING else S.PENALTY_ANIMATION_IN
        out.append(_t(source, target, "penalized", lambda bb: bb.penalized))
    if falls:
        out += [
            _t(source, S.FALLING, "falling detected", lambda bb: bb.fall_detection and bb.falling is not None),
            _t(source, S.FALLEN, "lying on the ground", lambda bb: bb.stand_up and bb.fallen is not None),
        ]
    return out


def build_transitions() -> list[Transition]:
    return [
        # start-up: wait for hardware, then walk-ready
        _t(S.STARTUP, S.SHUTDOWN, "shutdown requested", lambda bb: bb.shutdown),
        _t(S.STARTUP, S.RECORD, "record mode on", lambda bb: bb.startup_done and bb.record),
        _t(S.STARTUP, S.PENALTY_ANIMATION_IN, "penalized", lambda bb: bb.startup_done and bb.penalized),
        _t(S.STARTUP, S.FALLEN, "lying after start-up",
           lambda bb: bb.startup_done and bb.stand_up and bb.fallen is not None),
        _t(S.STARTUP, S.CONTROLLABLE, "walk-ready done", lambda bb: bb.startup_done),
        # standing
        *_common(S.CONTROLLABLE),
        _t(S.CONTROLLABLE, S.ANIMATION_RUNNING, "external animation", lambda bb: bb.external_animation),
        _t(S.CONTROLLABLE, S.WALKING, "walking active", lambda bb: bb.walking_active),
        _t(S.CONTROLLABLE, S.MOTOR_OFF, "inactive too long",
           lambda bb: bb.motor_off_after_s > 0 and bb.idle_s > bb.motor_off_after_s),
        # walking
        *_common(S.WALKING),
        _t(S.WALKING, S.ANIMATION_RUNNING, "external animation", lambda bb: bb.external_animation),
        _t(S.WALKING, S.CONTROLLABLE, "walking stopped", lambda bb: not bb.walking_active),
        _t(S.WALKING_STOPPING, S.SHUTDOWN, "shutdown requested", lambda bb: bb.shutdown),
        _t(S.WALKING_STOPPING, S.HARDWARE_PROBLEM, "servos or IMU silent", lambda bb: not bb.hardware_ok),
        _t(S.WALKING_STOPPING, S.FALLING, "falling detected",
           lambda bb: bb.fall_detection and bb.falling is not None),
        _t(S.WALKING_STOPPING, S.PENALTY_ANIMATION_IN, "walk finished its steps",
           lambda bb: not bb.walking_active or _since_entry(bb) > bb.walking_stop_timeout_s),
        # external animations: fall detection is off while they play (they may tilt the robot on purpose)
        *_common(S.ANIMATION_RUNNING, falls=False),
        _t(S.ANIMATION_RUNNING, S.CONTROLLABLE, "animation over", lambda bb: not bb.external_animation),
        # falls
        _t(S.FALLING, S.HARDWARE_PROBLEM, "servos or IMU silent", lambda bb: not bb.hardware_ok),
        _t(S.FALLING, S.FALLEN, "falling animation done, lying",
           lambda bb: not bb.animation_busy and bb.fallen is not None),
        _t(S.FALLING, S.CONTROLLABLE, "falling animation done, caught",
           lambda bb: not bb.animation_busy and bb.falling is None and bb.upright and _since_entry(bb) > 1.0),
        _t(S.FALLEN, S.SHUTDOWN, "shutdown requested", lambda bb: bb.shutdown),
        _t(S.FALLEN, S.HARDWARE_PROBLEM, "servos or IMU silent", lambda bb: not bb.hardware_ok),
        _t(S.FALLEN, S.PENALTY_ANIMATION_IN, "penalized", lambda bb: bb.penalized and not bb.animation_busy),
        _t(S.FALLEN, S.GETTING_UP, "lying on front or back",
           lambda bb: bb.stand_up and not bb.animation_busy and bb.fallen in (Side.FRONT, Side.BACK)),
        _t(S.FALLEN, S.GETTING_UP, "propped up, leaning to front or back",
           lambda bb: bb.stand_up and not bb.animation_busy and _lying_on(bb) in (Side.FRONT, Side.BACK)),
        _t(S.FALLEN, S.CONTROLLABLE, "upright and at rest",
           lambda bb: not bb.animation_busy and bb.fallen is None and bb.upright and _since_entry(bb) > 1.0),
        _t(S.GETTING_UP, S.HARDWARE_PROBLEM, "servos or IMU silent", lambda bb: not bb.hardware_ok),
        # a penalty comes before the fall branches (the Bit-Bots DSD's order): the referee took the robot off for
        # lying too long, so the stand-up stops and FALLEN goes on to the penalty at once (through FALLEN: no
        # edge of its own, the graph stays readable); a robot up on its feet settles first (at most a second)
        _t(S.GETTING_UP, S.FALLEN, "penalized", lambda bb: bb.penalized),
        # stand_up_back may end lying on the front (it rolls over): then stand up from there at once
        _t(S.GETTING_UP, S.FALLEN, "stand-up left it lying",
           lambda bb: not bb.animation_busy and bb.fallen is not None),
        # ...or still tipping, neither lying at rest nor upright (rolling over, or shaken by a robot it lies on): FALLEN
        # waits for it to lie still or tries again from where it leans (in a match one waited here 6.6 s, entangled)
        _t(S.GETTING_UP, S.FALLEN, "stand-up left it tipping",
           lambda bb: not bb.animation_busy and not bb.upright and bb.falling is not None),
        # a robot that ends its stand-up neither upright nor tipping settles: walk-ready, then standing or lying
        _t(S.GETTING_UP, S.GETTING_UP_SETTLE, "stand-up animation done",
           lambda bb: not bb.animation_busy and (bb.upright or bb.falling is None)),
        _t(S.GETTING_UP_SETTLE, S.FALLING, "falling again",
           lambda bb: not bb.animation_busy and bb.falling is not None),
        _t(S.GETTING_UP_SETTLE, S.FALLEN, "penalized", lambda bb: bb.penalized and not bb.upright),
        _t(S.GETTING_UP_SETTLE, S.FALLEN, "still lying", lambda bb: not bb.animation_busy and bb.fallen is not None),
        _t(S.GETTING_UP_SETTLE, S.CONTROLLABLE, "standing", lambda bb: not bb.animation_busy and bb.upright),
        _t(S.GETTING_UP_SETTLE, S.FALLEN, "not upright after stand-up",
           lambda bb: not bb.animation_busy and not bb.upright and _since_entry(bb) > 2.0),
        # penalty
        _t(S.PENALTY_ANIMATION_IN, S.SHUTDOWN, "shutdown requested", lambda bb: bb.shutdown),
        _t(S.PENALTY_ANIMATION_IN, S.PENALTY, "penalty animation done", lambda bb: not bb.animation_busy),
        _t(S.PENALTY, S.SHUTDOWN, "shutdown requested", lambda bb: bb.shutdown),
        _t(S.PENALTY, S.RECORD, "record mode on", lambda bb: bb.record),
        _t(S.PENALTY, S.PENALTY_ANIMATION_OUT, "unpenalized", lambda bb: not bb.penalized),
        _t(S.PENALTY_ANIMATION_OUT, S.PENALTY_ANIMATION_IN, "penalized again", lambda bb: bb.penalized),
        _t(S.PENALTY_ANIMATION_OUT, S.CONTROLLABLE, "stand-up done", lambda bb: not bb.animation_busy),
        # lab and power
        _t(S.RECORD, S.SHUTDOWN, "shutdown requested", lambda bb: bb.shutdown),
        _t(S.RECORD, S.STARTUP, "record mode off", lambda bb: not bb.record),
        *_common(S.MOTOR_OFF, falls=False),
        _t(S.MOTOR_OFF, S.STARTUP, "motion requested", lambda bb: bb.motion_requested),
        _t(S.HARDWARE_PROBLEM, S.SHUTDOWN, "shutdown requested", lambda bb: bb.shutdown),
        _t(S.HARDWARE_PROBLEM, S.STARTUP, "servos and IMU back", lambda bb: bb.hardware_ok),
        _t(S.SHUTDOWN, S.HCM_OFF, "shutdown animation done",
           lambda bb: not bb.animation_busy or _since_entry(bb) > bb.shutdown_timeout_s),
    ]


@dataclass
class HistoryEntry:
    state: HcmState
    wall_time: float
    condition: str


@dataclass
class HcmStateMachine:
    """Runs the table; entry and exit actions go through HcmActions."""

    actions: HcmActions
    animations: dict[str, str] = field(default_factory=dict)  # role -> animation name
    penalty_torque_off: bool = True
    state: HcmState = HcmState.STARTUP
    transitions: list[Transition] = field(default_factory=build_transitions)
    history: deque[HistoryEntry] = field(default_factory=lambda: deque(maxlen=50))
    fall_side: Side = Side.FRONT
    _startup_played: bool = False

    def __post_init__(self) -> None:
        self.history.append(HistoryEntry(self.state, time.time(), "start"))

    def anim(self, role: str) -> str:
        return self.animations.get(role, role)

    def step(self, bb: Blackboard) -> bool:
        """One evaluation; True if the state changed."""
        self._during(bb)
        for transition in self.transitions:
            if transition.source is self.state and transition.test(bb):
                self._change(transition, bb)
                return True
        return False

    def _change(self, transition: Transition, bb: Blackboard) -> None:
        self._exit(self.state, bb)
        self.state = transition.target
        bb.entered_at = bb.now
        self.history.append(HistoryEntry(self.state, time.time(), transition.condition))
        self._entry(self.state, bb)

    def _during(self, bb: Blackboard) -> None:
        if self.state is S.STARTUP and bb.hardware_ok and not self._startup_played:
            self._startup_played = True
            self.actions.torque(True)
            self.actions.play(self.anim("walkready"))
            bb.animation_busy = True
        bb.startup_done = self._startup_played and not bb.animation_busy
        if self.state is S.FALLEN and _lying_on(bb) in (Side.LEFT, Side.RIGHT) and not bb.animation_busy:
            # no stand-up from the side: tip the robot onto its front or back first (a robot's own animation, or
            # walk-ready as Bit-Bots do), then a later step finds it lying there and stands up
            self.actions.play(self.anim("turning_front"))
            bb.animation_busy = True

    def _entry(self, state: HcmState, bb: Blackboard) -> None:
        play = self.actions.play
        if state is S.STARTUP:
            self._startup_played = False
        elif state is S.FALLING:
            self.fall_side = bb.falling or self.fall_side
            play(self.anim(f"falling_{self.fall_side.value}"))
        elif state is S.FALLEN:
            self.fall_side = bb.fallen or self.fall_side
            if bb.penalized and bb.animation_busy:  # a stand-up cut short by a penalty
                self.actions.cancel_animation()
                bb.animation_busy = False
        elif state is S.GETTING_UP:
            side = bb.fallen or bb.leaning  # where it lies, or where it leans when propped up
            play(self.anim(f"stand_up_{side.value}"))
        elif state in (S.GETTING_UP_SETTLE,):
            play(self.anim("walkready"))
        elif state is S.PENALTY_ANIMATION_IN:
            self.actions.speak("penalized", 1)
            play(self.anim("penalty_in"))
        elif state is S.PENALTY:
            if self.penalty_torque_off:
                self.actions.torque(False)
        elif state is S.PENALTY_ANIMATION_OUT:
            self.actions.torque(True)
            play(self.anim("penalty_out"))
        elif state is S.RECORD or state is S.HARDWARE_PROBLEM:
            self.actions.cancel_animation()
            if state is S.HARDWARE_PROBLEM:
                self.actions.speak("hardware problem: servos or IMU silent", 2)
        elif state is S.MOTOR_OFF or state is S.HCM_OFF:
            self.actions.torque(False)
        elif state is S.SHUTDOWN:
            play(self.anim("shutdown"))
        if state in (S.FALLING, S.GETTING_UP, S.GETTING_UP_SETTLE, S.PENALTY_ANIMATION_IN,
                     S.PENALTY_ANIMATION_OUT, S.SHUTDOWN):
            bb.animation_busy = True

    def _exit(self, state: HcmState, bb: Blackboard) -> None:
        if state is S.PENALTY and self.penalty_torque_off:
            self.actions.torque(True)

    def graph(self) -> tuple[list[str], list[tuple[str, str, str]]]:
        """States and (from, to, condition) transitions, for the dashboard."""
        return ([s.value for s in HcmState],
                [(t.source.value, t.target.value, t.condition) for t in self.transitions])
