"""The joint mutex: which goal stream may reach the motors in which HCM state (specs/hcm.md 4.1)."""

from __future__ import annotations

import enum

from robot_nodes.hcm.state_machine import HcmState

S = HcmState


class GoalSource(enum.Enum):
    WALKING = "walk_motor_goals"
    HEAD = "head_motor_goals"
    ANIMATION = "animation"
    HCM_ANIMATION = "animation (requested by the HCM)"
    RECORD = "record_motor_goals"


PASSES_IN: dict[GoalSource, frozenset[HcmState]] = {
    GoalSource.WALKING: frozenset({S.CONTROLLABLE, S.WALKING, S.WALKING_STOPPING}),
    GoalSource.HEAD: frozenset({S.CONTROLLABLE, S.WALKING, S.WALKING_STOPPING}),
    GoalSource.ANIMATION: frozenset({S.ANIMATION_RUNNING}),
    # the HCM's own animations pass wherever it plays them; in RECORD and without power nothing does
    GoalSource.HCM_ANIMATION: frozenset(set(HcmState) - {S.RECORD, S.MOTOR_OFF, S.HCM_OFF, S.PENALTY}),
    GoalSource.RECORD: frozenset({S.RECORD}),
}


def passes(source: GoalSource, state: HcmState) -> bool:
    return state in PASSES_IN[source]
