"""What the plots show: a robot message turned into named series (rerun entities) and state lanes.

Pure data, no rerun here (server.plots does the logging). An entity holds all values of one kind at once (every
joint's position, the three gyro axes): one row per message instead of one per number keeps rerun's buffers
small. Paths are under the robot:

- ``joints/position`` and ``joints/goal``: every joint in the order of the robot's ``joint_states``; a goal holds
  until the next one for that joint (as the servo does), NaN (a gap) before the first;
- ``imu/angular_velocity``, ``imu/linear_acceleration``;
- ``loop_rates/<node>``: the ``rate_hz/*`` values of each node's diagnostics;
- ``topics/<topic>/<field path>``: every numeric field of a topic chosen in the panel (or of all topics, with
  ``--plots-all-topics``), from schemas.numeric, grouped by parent;
- ``lanes/hcm``, ``lanes/game``, ``lanes/penalized``: state names (server.plots logs their changes).
"""

from __future__ import annotations

import contextlib
import math
from collections import defaultdict
from dataclasses import dataclass, field

import schemas
from schemas.numeric import numeric_fields
from server.hub import BULK_TYPES, HubMessage

_HCM_NAMES = schemas.constant_names("humanoid_league_msgs/msg/RobotControlState")
_GAME_NAMES = schemas.constant_names("humanoid_league_msgs/msg/GameState", "GAMESTATE_")
_SECONDARY_NAMES = {v: name for v, name in schemas.constant_names("humanoid_league_msgs/msg/GameState", "STATE_")
                    .items() if name != "NORMAL"}
STATE_TOPICS = ("robot_state", "gamestate")
CURATED_TOPICS = ("joint_states", "motor_goals", "imu/data", "diagnostics")
RATE_PREFIX = "rate_hz/"


@dataclass(frozen=True, slots=True)
class Series:
    """The values of one entity at one time, one named line each."""

    names: tuple[str, ...]
    values: tuple[float, ...]


def states_of(msg: HubMessage) -> dict[str, str]:
    """Entity path -> state name, for the lanes: HCM state, game state, penalized."""
    if msg.topic == "robot_state":
        state = msg.message.state
        return {"lanes/hcm": _HCM_NAMES.get(state, f"state {state}")}
    if msg.topic == "gamestate":
        m = msg.message
        game = _GAME_NAMES.get(m.game_state, f"state {m.game_state}")
        if m.secondary_state in _SECONDARY_NAMES:
            game += f" / {_SECONDARY_NAMES[m.secondary_state]}"
        return {"lanes/game": game, "lanes/penalized": "penalized" if m.penalized else "in play"}
    return {}


def topic_series(msg: HubMessage) -> dict[str, Series]:
    """``topics/<topic>[/<parent>]`` -> the message's numbers under that parent, named by their last path part."""
    if msg.typename in BULK_TYPES:
        return {}
    groups: dict[str, tuple[list[str], list[float]]] = defaultdict(lambda: ([], []))
    for path, value in numeric_fields(msg.message):
        parent, _, name = path.rpartition("/")
        names, values = groups[f"topics/{msg.topic}/{parent}" if parent else f"topics/{msg.topic}"]
        names.append(name)
        values.append(value)
    return {entity: Series(tuple(names), tuple(values)) for entity, (names, values) in groups.items()}


@dataclass
class RobotSeries:
    """One robot's curated series; remembers its joint order and the goals that still hold."""

    joints: list[str] = field(default_factory=list)
    goals: dict[str, float] = field(default_factory=dict)

    def series(self, msg: HubMessage) -> dict[str, Series]:
        if msg.topic not in CURATED_TOPICS:
            return {}
        m = msg.message
        if msg.topic == "joint_states":
            self.joints = [str(n) for n in m.name]
            return {"joints/position": Series(tuple(self.joints), tuple(float(p) for p in m.position))}
        if msg.topic == "motor_goals" and m.points:
            self.goals.update(zip(m.joint_names, (float(p) for p in m.points[-1].positions), strict=False))
            order = self.joints or sorted(self.goals)
            return {"joints/goal": Series(tuple(order), tuple(self.goals.get(j, math.nan) for j in order))}
        if msg.topic == "imu/data":
            return {f"imu/{kind}": Series(tuple(f"{label} {a}" for a in "xyz"),
                                          tuple(float(getattr(getattr(m, kind), a)) for a in "xyz"))
                    for kind, label in (("angular_velocity", "gyro"), ("linear_acceleration", "acc"))}
        if msg.topic == "diagnostics":
            out: dict[str, Series] = {}
            for status in m.status:
                rates: dict[str, float] = {}
                for kv in status.values:
                    if kv.key.startswith(RATE_PREFIX):
                        with contextlib.suppress(ValueError):
                            rates[kv.key[len(RATE_PREFIX):]] = float(kv.value)
                if rates:
                    node = status.name.rsplit("/", 1)[-1]
                    out[f"loop_rates/{node}"] = Series(tuple(f"{node} {k}" for k in rates), tuple(rates.values()))
            return out
        return {}
