"""Fuzzing the decoders of outside network input: GameController packets (HL v12, HSL v19/v20, return and status
packets), Mitecom and the protobuf team message.

Each decoder may only raise its documented error. The default run tries FAST_EXAMPLES inputs per strategy
(three strategies per decoder). The full run brings every decoder to at least 100,000 generated inputs; it takes
about 10 minutes on this 2-core machine under load (102,000 each: GameController 161 s, Mitecom 304 s,
protobuf 141 s), too long for every CI run, so it is opt-in:
``PITCHSIDE_FUZZ_FULL=1 .venv/bin/python -m pytest tests/test_network_fuzz.py -m slow -s`` (prints the figures).
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robot_nodes.mitecom import codec, protobuf_codec
from robot_nodes.mitecom import team_message_pb2 as pb
from robot_nodes.mitecom.codec import MitecomError
from robot_nodes.mitecom.protobuf_codec import TeamMessageError
from tests.support import TESTDATA
from wire.gamecontroller.monitor import parse_forwarded_status, parse_true_data
from wire.gamecontroller.packets import (
    HSL_PACKET_SIZE,
    PACKET_SIZE,
    PACKET_SIZE_2018,
    GameControllerPacketError,
    StatusPacket,
    build_state_packet,
    build_status_packet,
    hl_to_hsl,
    parse_any_return_packet,
    parse_return_packet,
    parse_state_packet,
)

FAST_EXAMPLES = 500
SLOW_EXAMPLES = 34_000  # per strategy; three strategies per decoder -> 102,000 inputs each
CAPTURES = [p.read_bytes() for p in sorted((TESTDATA / "gamecontroller").glob("*.bin"))]


def _mutated(seeds: list[bytes]) -> st.SearchStrategy[bytes]:
    """A seed with bytes overwritten, then cut or extended: close enough to pass the first checks."""
    @st.composite
    def build(draw: st.DrawFn) -> bytes:
        data = bytearray(draw(st.sampled_from(seeds)))
        for _ in range(draw(st.integers(0, 12))):
            if data:
                data[draw(st.integers(0, len(data) - 1))] = draw(st.integers(0, 255))
        cut = draw(st.sampled_from(["keep", "keep", "truncate", "extend"]))
        if cut == "truncate" and data:
            data = data[:draw(st.integers(0, len(data) - 1))]
        elif cut == "extend":
            data += draw(st.binary(min_size=1, max_size=16))
        return bytes(data)
    return build()


# -- strategies per decoder ---------------------------------------------------------------------------------

GC_STRATEGIES = {
    "random": st.binary(max_size=800),
    "header_and_size": st.sampled_from([PACKET_SIZE, PACKET_SIZE_2018]).flatmap(
        lambda n: st.binary(min_size=n - 6, max_size=n - 6).map(lambda body: b"RGme\x0c\x00" + body)),
    "mutated_captures": _mutated(CAPTURES),
}

_HSL_SEEDS = [build_state_packet(hl_to_hsl(parse_state_packet(c), v)) for c in CAPTURES[:4] for v in (19, 20)]
_STATUS_SEED = build_status_packet(StatusPacket(5, 2, 0, (-1500.0, 800.0, 1.5), 0.4, (1200.0, -300.0)))
HSL_STRATEGIES = {
    "random": st.binary(max_size=260).map(lambda body: b"RGme" + body),
    "header_and_size": st.sampled_from(sorted(HSL_PACKET_SIZE.items())).flatmap(
        lambda vn: st.binary(min_size=vn[1] - 5, max_size=vn[1] - 5).map(lambda body: b"RGme" + bytes([vn[0]]) + body)),
    "mutated_packets": _mutated([*_HSL_SEEDS, _STATUS_SEED]),
}

_MITECOM_SEED = codec.encode_pairs(5, 3, {0: 2, 1: 2, 2: 1, 0x10000: -1500, 0x10001: 800, 0x10002: 90,
                                          0x10003: 200, 0x10004: 1200, 0x10005: -300, 0x10006: 180, 0x20001: 15})


@st.composite
def _mitecom_pairs(draw: st.DrawFn) -> bytes:
    """Well-formed headers with arbitrary keys (known ones favoured) and int32 values."""
    known = st.sampled_from([int(k) for k in codec.Key] + [int(codec.Key.OPPONENT_ROBOT_A_X) + i for i in range(18)])
    keys = draw(st.lists(st.one_of(known, st.integers(0, 2**32 - 1)), max_size=40))
    pairs = {k: draw(st.integers(-(2**31), 2**31 - 1)) for k in keys}
    header_fix = draw(st.sampled_from(["ok", "ok", "ok", "count", "robot0"]))
    data = bytearray(codec.encode_pairs(draw(st.integers(0, 0xFFFF)), draw(st.integers(1, 0xFFFF)), pairs))
    if header_fix == "count":
        data[6:8] = draw(st.integers(0, 0xFFFF)).to_bytes(2, "little")
    elif header_fix == "robot0":
        data[14:16] = b"\0\0"
    return bytes(data)


MITECOM_STRATEGIES = {
    "random": st.binary(max_size=400),
    "pairs": _mitecom_pairs(),
    "mutated": _mutated([_MITECOM_SEED, _MITECOM_SEED[:16]]),
}

_floats = st.floats(width=32, allow_nan=True, allow_infinity=True)


@st.composite
def _team_message(draw: st.DrawFn) -> bytes:
    """Serialized messages with arbitrary field values, including out-of-range enums and NaN."""
    msg = pb.Message()
    msg.current_pose.player_id = draw(st.integers(0, 2**32 - 1))
    if draw(st.booleans()):
        msg.current_pose.position.x, msg.current_pose.position.y, msg.current_pose.position.z = (
            draw(_floats), draw(_floats), draw(_floats))
    msg.current_pose.team = draw(st.integers(-5, 5))  # type: ignore[assignment]
    msg.state = draw(st.integers(-3, 5))  # type: ignore[assignment]
    if draw(st.booleans()):
        msg.ball.position.x, msg.ball.position.y = draw(_floats), draw(_floats)
    for _ in range(draw(st.integers(0, 4))):
        other = msg.others.add()
        other.position.x, other.position.y = draw(_floats), draw(_floats)
        other.team = draw(st.integers(0, 3))
    msg.other_robot_confidence.extend(draw(st.lists(_floats, max_size=5)))
    msg.role = draw(st.integers(-2, 9))  # type: ignore[assignment]
    msg.action = draw(st.integers(-2, 12))  # type: ignore[assignment]
    msg.offensive_side = draw(st.integers(-2, 6))  # type: ignore[assignment]
    msg.max_walking_speed = draw(_floats)
    msg.time_to_ball = draw(_floats)
    if draw(st.booleans()):
        msg.walk_command.x, msg.walk_command.y, msg.walk_command.z = draw(_floats), draw(_floats), draw(_floats)
    return msg.SerializeToString()


_PB_SEED = pb.Message()
_PB_SEED.current_pose.player_id = 3
_PB_SEED.current_pose.position.x = 1.0
_PB_SEED.ball.position.y = 2.0
_PB_SEED.role = pb.ROLE_GOALIE

PROTOBUF_STRATEGIES = {
    "random": st.binary(max_size=600),
    "messages": _team_message(),
    "mutated": _mutated([_PB_SEED.SerializeToString()]),
}


# -- properties ---------------------------------------------------------------------------------------------

KINDS = {"truncated", "over_long", "wrong_header", "wrong_version", "bad_value"}


def check_gc(data: bytes) -> None:
    try:
        packet = parse_state_packet(data)
    except GameControllerPacketError as exc:
        assert str(exc) and exc.kind in KINDS
    else:
        # what was read can be sent again and reads the same
        assert parse_state_packet(build_state_packet(packet)) == packet
        if packet.version in HSL_PACKET_SIZE:
            assert build_state_packet(packet) == data, "an HSL packet keeps every byte"
    try:
        parse_return_packet(data)
    except GameControllerPacketError as exc:
        assert str(exc)
    try:
        status = parse_any_return_packet(data)
    except GameControllerPacketError as exc:
        assert str(exc) and exc.kind in KINDS
    else:
        if isinstance(status, StatusPacket) and all(math.isfinite(v) for v in (*status.pose_mm, *status.ball_mm,
                                                                                  status.ball_age_s)):
            assert build_status_packet(status) == data
    for monitor_decoder in (parse_true_data, parse_forwarded_status):  # what a GameController monitor receives
        try:
            monitor_decoder(data)
        except GameControllerPacketError as exc:
            assert str(exc) and exc.kind in KINDS


def check_mitecom(data: bytes) -> None:
    try:
        report = codec.decode(data)
    except MitecomError as exc:
        assert str(exc)
    else:
        assert codec.decode(codec.encode(report)) == report


def check_protobuf(data: bytes) -> None:
    try:
        report = protobuf_codec.decode(data)
    except TeamMessageError as exc:
        assert str(exc)
    else:
        assert 1 <= report.robot_id <= 255
        if report.position is not None:
            assert all(math.isfinite(v) for v in report.position)
        protobuf_codec.encode(report)  # what was read can be sent again


CASES: list[tuple[str, Callable[[bytes], None], dict[str, st.SearchStrategy[bytes]]]] = [
    ("gamecontroller", check_gc, GC_STRATEGIES),
    ("gamecontroller_hsl", check_gc, HSL_STRATEGIES),
    ("mitecom", check_mitecom, MITECOM_STRATEGIES),
    ("protobuf", check_protobuf, PROTOBUF_STRATEGIES),
]
PARAMS = [(name, check, s_name, strategy) for name, check, strategies in CASES
          for s_name, strategy in strategies.items()]
IDS = [f"{p[0]}-{p[2]}" for p in PARAMS]


def _run(check: Callable[[bytes], None], strategy: st.SearchStrategy[bytes], examples: int) -> int:
    count = 0

    @settings(max_examples=examples, deadline=None, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
    @given(strategy)
    def run(data: bytes) -> None:
        nonlocal count
        count += 1
        check(data)

    run()
    return count


@pytest.mark.parametrize(("decoder", "check", "strategy_name", "strategy"), PARAMS, ids=IDS)
def test_decoder_fuzz(decoder: str, check: Callable[[bytes], None], strategy_name: str,
                      strategy: st.SearchStrategy[bytes]) -> None:
    assert _run(check, strategy, FAST_EXAMPLES) >= FAST_EXAMPLES // 2


@pytest.mark.slow
@pytest.mark.skipif(not os.environ.get("PITCHSIDE_FUZZ_FULL"),
                    reason="100k inputs per decoder: set PITCHSIDE_FUZZ_FULL=1")
@pytest.mark.timeout(1800)
@pytest.mark.parametrize("decoder", [c[0] for c in CASES])
def test_decoder_fuzz_100k(decoder: str) -> None:
    _, check, strategies = next(c for c in CASES if c[0] == decoder)
    started = time.perf_counter()
    total = sum(_run(check, strategy, SLOW_EXAMPLES) for strategy in strategies.values())
    took = time.perf_counter() - started
    print(f"\n{decoder}: {total} generated inputs in {took:.1f} s ({total / took:.0f}/s)")
    assert total >= 100_000
