"""The behaviour's state machine: states, and transitions as a table of (source, target, condition, test).

``step`` takes the first transition from the present state whose test holds, so the table reads top to bottom as the
priorities: penalty, a robot that cannot move, the GameController's state, then the role's own moves. The graph the
dashboard draws (behavior_graph) is this very table.
"""

from __future__ import annotations

import enum
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

from robot_nodes.behavior.roles import DEFENDER, GOALIE, STRIKER, SUPPORTER
from schemas.messages import GameState


class State(enum.Enum):
    START = "START"  # no GameController state heard yet
    INITIAL = "INITIAL"
    READY_GO = "READY_GO_TO_POSITION"
    READY_WAIT = "READY_AT_POSITION"
    SET = "SET"
    WAIT = "PLAYING_NOT_ALLOWED_TO_MOVE"
    GOALIE = "GOALIE_GUARD_GOAL"
    SEARCH_BALL = "STRIKER_SEARCH_BALL"
    GO_TO_BALL = "STRIKER_GO_TO_BALL"
    KICK = "STRIKER_KICK"
    SUPPORT = "SUPPORTER_POSITION"
    DEFEND = "DEFENDER_POSITION"
    FINISHED = "FINISHED"
    PENALIZED = "PENALIZED"
    HCM_BUSY = "WAIT_FOR_HCM"  # falling, getting up, an animation not its own: the HCM has the robot


S = State
PLAYING_STATES = frozenset({S.WAIT, S.GOALIE, S.SEARCH_BALL, S.GO_TO_BALL, S.KICK, S.SUPPORT, S.DEFEND})
ROLE_STATES = frozenset({S.GOALIE, S.SEARCH_BALL, S.GO_TO_BALL, S.KICK, S.SUPPORT, S.DEFEND})
STANDING_STATES = frozenset({S.START, S.INITIAL, S.READY_WAIT, S.SET, S.WAIT, S.FINISHED, S.PENALIZED, S.HCM_BUSY})


@dataclass
class Blackboard:
    """What the transitions look at; the node refreshes it before every step."""

    game_state: int | None = None
    penalized: bool = False
    controllable: bool = False  # the HCM lets the robot walk (CONTROLLABLE or WALKING)
    allowed_to_move: bool = True
    role: int = STRIKER
    ball_known: bool = False
    at_ready_position: bool = False
    near_ready_position: bool = False
    kick_ready: bool = False  # the striker stands behind the ball, facing the goal
    kick_over: bool = False


@dataclass(frozen=True)
class Transition:
    source: State
    target: State
    condition: str
    test: Callable[[Blackboard], bool]


def _playing(bb: Blackboard) -> bool:
    return bb.game_state == GameState.GAMESTATE_PLAYING


def _playing_moving(bb: Blackboard) -> bool:
    return _free(bb) and _playing(bb) and bb.allowed_to_move


def _free(bb: Blackboard) -> bool:
    """Neither penalized nor held by the HCM: the game's phase decides."""
    return not bb.penalized and bb.controllable


def _when_free(test: Callable[[Blackboard], bool]) -> Callable[[Blackboard], bool]:
    return lambda bb: _free(bb) and test(bb)


def _common(source: State) -> list[Transition]:
    """What every state checks first: penalty, the HCM, and the game's phase (never to the phase it is in)."""
    t = Transition
    out = []
    if source is not S.PENALIZED:
        out.append(t(source, S.PENALIZED, "penalized", lambda bb: bb.penalized))
    if source not in (S.HCM_BUSY, S.KICK):  # a kick's animation is the HCM's too: the kick ends it
        out.append(t(source, S.HCM_BUSY, "the HCM has the robot (fall, get-up, animation)",
                     lambda bb: not bb.penalized and not bb.controllable))
    phases: list[tuple[State, str, Callable[[Blackboard], bool], set[State]]] = [
        (S.INITIAL, "INITIAL", lambda bb: bb.game_state == GameState.GAMESTATE_INITIAL, {S.INITIAL}),
        (S.READY_GO, "READY", lambda bb: bb.game_state == GameState.GAMESTATE_READY, {S.READY_GO, S.READY_WAIT}),
        (S.SET, "SET", lambda bb: bb.game_state == GameState.GAMESTATE_SET, {S.SET}),
        (S.FINISHED, "FINISHED", lambda bb: bb.game_state == GameState.GAMESTATE_FINISHED, {S.FINISHED}),
        (S.WAIT, "PLAYING, not allowed to move", lambda bb: _playing(bb) and not bb.allowed_to_move, {S.WAIT}),
    ]
    for target, condition, test, inside in phases:
        if source not in inside:
            out.append(t(source, target, condition, _when_free(test)))
    if source not in ROLE_STATES:
        out += [
            t(source, S.GOALIE, "PLAYING: goalie", lambda bb: _playing_moving(bb) and bb.role == GOALIE),
            t(source, S.SEARCH_BALL, "PLAYING: striker, ball unknown",
              lambda bb: _playing_moving(bb) and bb.role == STRIKER and not bb.ball_known),
            t(source, S.GO_TO_BALL, "PLAYING: striker", lambda bb: _playing_moving(bb) and bb.role == STRIKER),
            t(source, S.SUPPORT, "PLAYING: supporter", lambda bb: _playing_moving(bb) and bb.role == SUPPORTER),
            t(source, S.DEFEND, "PLAYING: defender", lambda bb: _playing_moving(bb) and bb.role == DEFENDER),
        ]
    return out


def _role_changes(source: State) -> list[Transition]:
    """A role state left for another role's state when team communication changes the role."""
    t = Transition
    targets = [(S.GOALIE, "became goalie", lambda bb: bb.role == GOALIE),
               (S.GO_TO_BALL, "became striker", lambda bb: bb.role == STRIKER),
               (S.SUPPORT, "became supporter", lambda bb: bb.role == SUPPORTER),
               (S.DEFEND, "became defender", lambda bb: bb.role == DEFENDER)]
    striker_states = (S.SEARCH_BALL, S.GO_TO_BALL)
    return [t(source, target, condition, test) for target, condition, test in targets
            if target is not source and not (source in striker_states and target is S.GO_TO_BALL)]


def build_transitions() -> list[Transition]:
    t = Transition
    table: list[Transition] = []
    for state in State:
        table += _common(state)
        if state is S.READY_GO:
            table.append(t(state, S.READY_WAIT, "at the kick-off position", lambda bb: bb.at_ready_position))
        elif state is S.READY_WAIT:
            table.append(t(state, S.READY_GO, "pushed off the position", lambda bb: not bb.near_ready_position))
        elif state is S.SEARCH_BALL:
            table += _role_changes(state)
            table.append(t(state, S.GO_TO_BALL, "ball found", lambda bb: bb.ball_known))
        elif state is S.GO_TO_BALL:
            table += _role_changes(state)
            table.append(t(state, S.SEARCH_BALL, "ball lost", lambda bb: not bb.ball_known))
            table.append(t(state, S.KICK, "behind the ball, facing the goal", lambda bb: bb.kick_ready))
        elif state is S.KICK:
            table.append(t(state, S.GO_TO_BALL, "kick over", lambda bb: bb.kick_over))
        elif state in (S.GOALIE, S.SUPPORT, S.DEFEND):
            table += _role_changes(state)
    return table


@dataclass
class HistoryEntry:
    state: State
    wall_time: float
    condition: str


@dataclass
class BehaviorStateMachine:
    """Runs the table; the node does what each state means."""

    state: State = State.START
    transitions: list[Transition] = field(default_factory=build_transitions)
    history: deque[HistoryEntry] = field(default_factory=lambda: deque(maxlen=50))

    def __post_init__(self) -> None:
        self.history.append(HistoryEntry(self.state, time.time(), "start"))

    def step(self, bb: Blackboard) -> Transition | None:
        """One evaluation: the transition taken, or None."""
        for transition in self.transitions:
            if transition.source is self.state and transition.test(bb):
                self.state = transition.target
                self.history.append(HistoryEntry(self.state, time.time(), transition.condition))
                return transition
        return None

    def graph(self) -> tuple[list[str], list[tuple[str, str, str]]]:
        """States and (from, to, condition) transitions, for the dashboard."""
        return ([s.value for s in State],
                [(t.source.value, t.target.value, t.condition) for t in self.transitions])
