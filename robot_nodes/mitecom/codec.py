"""Mitecom wire format (FUmanoids, 2013/2017): 16-byte header + int32 key/value pairs, little endian.

Layout, keys and units: /work/shared/specs/mitecom.md. Distances travel in mm, beliefs as 0..255, walking
speed in cm/s; `TeammateReport` holds metres, radians, m/s and 0..1.
"""

from __future__ import annotations

import math
import struct
from enum import IntEnum

from robot_nodes.mitecom.report import (
    HCM_CONTROLLABLE,
    HCM_INACTIVE_STATES,
    HCM_PENALIZED_STATES,
    HCM_PENALTY,
    HCM_STARTUP,
    SeenRobot,
    TeammateReport,
)

MAGIC = 0x4D585443  # 'MXTC'; on the wire 43 54 58 4d
VERSION = 1
DEFAULT_PORT = 12321
_HEADER = struct.Struct("<IHHIHH")
_PAIR = struct.Struct("<Ii")
HEADER_SIZE = _HEADER.size  # 16
INT32_MIN, INT32_MAX = -(2**31), 2**31 - 1


class MitecomError(ValueError):
    """A datagram that is not a valid Mitecom message, or a report that cannot be sent; the message says why."""


class Key(IntEnum):
    ROBOT_CURRENT_ROLE = 0x00000000
    ROBOT_CURRENT_ACTION = 0x00000001
    ROBOT_CURRENT_STATE = 0x00000002
    ROBOT_ABSOLUTE_X = 0x00010000
    ROBOT_ABSOLUTE_Y = 0x00010001
    ROBOT_ABSOLUTE_ORIENTATION = 0x00010002
    ROBOT_ABSOLUTE_BELIEF = 0x00010003
    BALL_RELATIVE_X = 0x00010004
    BALL_RELATIVE_Y = 0x00010005
    BALL_BELIEF = 0x00010006
    OPPGOAL_RELATIVE_X = 0x00010007
    OPPGOAL_RELATIVE_Y = 0x00010008
    OPPGOAL_RELATIVE_BELIEF = 0x00010009
    OPPONENT_ROBOT_A_X = 0x0001000A
    TEAM_ROBOT_A_X = 0x00010016
    ROBOT_AVG_WALKING_SPEED_IN_CM_PER_SECOND = 0x00020001
    ROBOT_TIME_TO_POSITION_AT_BALL_IN_SECONDS = 0x00020002
    ROBOT_MAX_KICKING_DISTANCE = 0x00020003
    OFFENSIVE_SIDE = 0x00030001
    # team-private range: the exact RobotControlState, which the 3-value Mitecom state cannot carry
    PITCHSIDE_HCM_STATE = 0x10000000


OPPONENT_SLOTS = 4  # A..D, three keys each (x, y, belief)
TEAM_SLOTS = 3  # A..C


class MitecomState(IntEnum):
    INACTIVE = 0
    ACTIVE = 1
    PENALIZED = 2


class MitecomSide(IntEnum):
    UNSPECIFIED = 0
    LEFT = 1
    MIDDLE = 2
    RIGHT = 3


class Orientation(IntEnum):
    """The spec says degrees; the Bit-Bots node sent milliradians. Pick per peer."""

    DEGREES = 0
    MILLIRADIANS = 1


# -- raw messages -------------------------------------------------------------------------------------------

def encode_pairs(team_id: int, robot_id: int, pairs: dict[int, int]) -> bytes:
    """A Mitecom datagram with the keys in ascending order, as the reference sender emits them."""
    if not 0 <= team_id <= 0xFFFF or not 1 <= robot_id <= 0xFFFF:
        raise MitecomError(f"team id must be 0..65535 and robot id 1..65535, got {team_id}, {robot_id}")
    if len(pairs) > 0xFFFF:
        raise MitecomError(f"too many key/value pairs: {len(pairs)}")
    out = bytearray(_HEADER.pack(MAGIC, VERSION, len(pairs), 0, team_id, robot_id))
    for key in sorted(pairs):
        value = pairs[key]
        if not 0 <= key <= 0xFFFFFFFF or not INT32_MIN <= value <= INT32_MAX:
            raise MitecomError(f"key 0x{key:08x} = {value} does not fit uint32/int32")
        out += _PAIR.pack(key, value)
    return bytes(out)


def decode_pairs(data: bytes | bytearray | memoryview) -> tuple[int, int, dict[int, int]]:
    """(team id, robot id, {key: value}); MitecomError for a wrong magic, version, length or robot id 0."""
    data = bytes(data)
    if len(data) < HEADER_SIZE:
        raise MitecomError(f"Mitecom message too short: {len(data)} bytes, the header alone is {HEADER_SIZE}")
    magic, version, count, _flags, team_id, robot_id = _HEADER.unpack_from(data)
    if magic != MAGIC:
        raise MitecomError(f"wrong Mitecom magic 0x{magic:08x}, expected 0x{MAGIC:08x} ('MXTC')")
    if version != VERSION:
        raise MitecomError(f"Mitecom version {version} is not supported, expected {VERSION}")
    if len(data) != HEADER_SIZE + count * _PAIR.size:
        raise MitecomError(
            f"Mitecom message says {count} pairs ({HEADER_SIZE + count * _PAIR.size} bytes) but has {len(data)} bytes"
        )
    if robot_id == 0:
        raise MitecomError("Mitecom robot id 0 is reserved as invalid")
    pairs = {key: value for key, value in _PAIR.iter_unpack(data[HEADER_SIZE:])}
    return team_id, robot_id, pairs


# -- units --------------------------------------------------------------------------------------------------

def _mm(metres: float) -> int:
    return _clamp(round(metres * 1000.0))


def _belief(confidence: float) -> int:
    return max(0, min(255, round(confidence * 255.0)))


def _clamp(value: int) -> int:
    return max(INT32_MIN, min(INT32_MAX, value))


def _finite(*values: float | None) -> bool:
    return all(v is not None and math.isfinite(v) for v in values)


def to_mitecom_state(hcm_state: int) -> MitecomState:
    """The Bit-Bots mapping of HCM states onto the three Mitecom states."""
    if hcm_state in HCM_PENALIZED_STATES:
        return MitecomState.PENALIZED
    if hcm_state in HCM_INACTIVE_STATES:
        return MitecomState.INACTIVE
    return MitecomState.ACTIVE


_FROM_MITECOM_STATE = {MitecomState.INACTIVE: HCM_STARTUP, MitecomState.ACTIVE: HCM_CONTROLLABLE,
                       MitecomState.PENALIZED: HCM_PENALTY}


# -- reports ------------------------------------------------------------------------------------------------

def report_to_pairs(report: TeammateReport, orientation: Orientation = Orientation.DEGREES,
                    private_keys: bool = True) -> dict[int, int]:
    """Only what the report knows: non-finite numbers are left out rather than sent as garbage.

    private_keys adds the team-private exact HCM state (other teams' receivers skip it).
    """
    pairs: dict[int, int] = {}
    if report.role is not None:
        pairs[Key.ROBOT_CURRENT_ROLE] = report.role
    if report.action is not None:
        pairs[Key.ROBOT_CURRENT_ACTION] = report.action
    if report.state is not None:
        pairs[Key.ROBOT_CURRENT_STATE] = to_mitecom_state(report.state)
        if private_keys:
            pairs[Key.PITCHSIDE_HCM_STATE] = report.state
    if report.offensive_side is not None:
        pairs[Key.OFFENSIVE_SIDE] = report.offensive_side + 1  # Strategy LEFT=0 -> Mitecom LEFT=1
    if report.position is not None and _finite(*report.position):
        x, y, theta = report.position
        pairs[Key.ROBOT_ABSOLUTE_X] = _mm(x)
        pairs[Key.ROBOT_ABSOLUTE_Y] = _mm(y)
        pairs[Key.ROBOT_ABSOLUTE_ORIENTATION] = _clamp(
            round(math.degrees(theta)) if orientation == Orientation.DEGREES else round(theta * 1000.0))
        pairs[Key.ROBOT_ABSOLUTE_BELIEF] = _belief(report.position_confidence)
    if report.ball is not None and _finite(*report.ball):
        pairs[Key.BALL_RELATIVE_X] = _mm(report.ball[0])
        pairs[Key.BALL_RELATIVE_Y] = _mm(report.ball[1])
        pairs[Key.BALL_BELIEF] = _belief(report.ball_confidence)
    if report.oppgoal is not None and _finite(*report.oppgoal):
        pairs[Key.OPPGOAL_RELATIVE_X] = _mm(report.oppgoal[0])
        pairs[Key.OPPGOAL_RELATIVE_Y] = _mm(report.oppgoal[1])
        pairs[Key.OPPGOAL_RELATIVE_BELIEF] = _belief(report.oppgoal_confidence)
    for base, slots, robots in ((Key.OPPONENT_ROBOT_A_X, OPPONENT_SLOTS, report.opponents),
                                (Key.TEAM_ROBOT_A_X, TEAM_SLOTS, report.teammates)):
        for i, robot in enumerate([r for r in robots if _finite(r.x, r.y, r.confidence)][:slots]):
            pairs[base + 3 * i] = _mm(robot.x)
            pairs[base + 3 * i + 1] = _mm(robot.y)
            pairs[base + 3 * i + 2] = _belief(robot.confidence)
    if report.walking_speed is not None and _finite(report.walking_speed):
        pairs[Key.ROBOT_AVG_WALKING_SPEED_IN_CM_PER_SECOND] = _clamp(round(report.walking_speed * 100.0))
    if report.time_to_ball is not None and _finite(report.time_to_ball):
        pairs[Key.ROBOT_TIME_TO_POSITION_AT_BALL_IN_SECONDS] = _clamp(round(report.time_to_ball))
    if report.max_kicking_distance is not None and _finite(report.max_kicking_distance):
        pairs[Key.ROBOT_MAX_KICKING_DISTANCE] = _mm(report.max_kicking_distance)  # mm, as Bit-Bots sent it
    return pairs


def report_from_pairs(team_id: int, robot_id: int, pairs: dict[int, int],
                      orientation: Orientation = Orientation.DEGREES) -> TeammateReport:
    """Unknown keys are skipped; a half-sent position (x without y) counts as not sent."""
    def m(key: int) -> float:
        return pairs[key] / 1000.0

    def belief(key: int) -> float:
        return max(0, min(255, pairs.get(key, 255))) / 255.0

    position = None
    if Key.ROBOT_ABSOLUTE_X in pairs and Key.ROBOT_ABSOLUTE_Y in pairs:
        raw_theta = pairs.get(Key.ROBOT_ABSOLUTE_ORIENTATION, 0)
        theta = math.radians(raw_theta) if orientation == Orientation.DEGREES else raw_theta / 1000.0
        position = (m(Key.ROBOT_ABSOLUTE_X), m(Key.ROBOT_ABSOLUTE_Y), theta)
    ball = (m(Key.BALL_RELATIVE_X), m(Key.BALL_RELATIVE_Y)) \
        if Key.BALL_RELATIVE_X in pairs and Key.BALL_RELATIVE_Y in pairs else None
    oppgoal = (m(Key.OPPGOAL_RELATIVE_X), m(Key.OPPGOAL_RELATIVE_Y)) \
        if Key.OPPGOAL_RELATIVE_X in pairs and Key.OPPGOAL_RELATIVE_Y in pairs else None
    seen: list[tuple[SeenRobot, ...]] = []
    for base, slots in ((Key.OPPONENT_ROBOT_A_X, OPPONENT_SLOTS), (Key.TEAM_ROBOT_A_X, TEAM_SLOTS)):
        robots = tuple(
            SeenRobot(m(base + 3 * i), m(base + 3 * i + 1), belief(base + 3 * i + 2))
            for i in range(slots) if base + 3 * i in pairs and base + 3 * i + 1 in pairs
        )
        seen.append(robots)
    state = pairs.get(Key.PITCHSIDE_HCM_STATE)
    if state is not None and not 0 <= state <= 255:
        state = None
    if state is None and Key.ROBOT_CURRENT_STATE in pairs:
        state = _FROM_MITECOM_STATE.get(pairs[Key.ROBOT_CURRENT_STATE])  # type: ignore[call-overload]
    side = pairs.get(Key.OFFENSIVE_SIDE)

    def small(key: int) -> int | None:
        value = pairs.get(key)
        return value if value is not None and 0 <= value <= 254 else None

    speed = pairs.get(Key.ROBOT_AVG_WALKING_SPEED_IN_CM_PER_SECOND)
    ttb = pairs.get(Key.ROBOT_TIME_TO_POSITION_AT_BALL_IN_SECONDS)
    kick = pairs.get(Key.ROBOT_MAX_KICKING_DISTANCE)
    return TeammateReport(
        robot_id=robot_id,
        team_id=team_id,
        role=small(Key.ROBOT_CURRENT_ROLE),
        action=small(Key.ROBOT_CURRENT_ACTION),
        state=state,
        offensive_side=side - 1 if side is not None and MitecomSide.LEFT <= side <= MitecomSide.RIGHT else None,
        position=position,
        position_confidence=belief(Key.ROBOT_ABSOLUTE_BELIEF) if position else 0.0,
        ball=ball,
        ball_confidence=belief(Key.BALL_BELIEF) if ball else 0.0,
        oppgoal=oppgoal,
        oppgoal_confidence=belief(Key.OPPGOAL_RELATIVE_BELIEF) if oppgoal else 0.0,
        opponents=seen[0],
        teammates=seen[1],
        walking_speed=speed / 100.0 if speed is not None else None,
        time_to_ball=float(ttb) if ttb is not None else None,
        max_kicking_distance=kick / 1000.0 if kick is not None else None,
    )


def encode(report: TeammateReport, orientation: Orientation = Orientation.DEGREES, private_keys: bool = True) -> bytes:
    return encode_pairs(report.team_id, report.robot_id, report_to_pairs(report, orientation, private_keys))


def decode(data: bytes | bytearray | memoryview, orientation: Orientation = Orientation.DEGREES) -> TeammateReport:
    """MitecomError (and nothing else) for a datagram that is not Mitecom."""
    team_id, robot_id, pairs = decode_pairs(data)
    return report_from_pairs(team_id, robot_id, pairs, orientation)
