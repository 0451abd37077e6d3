"""Fuzzing the telemetry receiver: over 100,000 generated datagrams, nothing escapes and nothing unexpected fails.

The three tests assert at least 35,000 + 50,000 + 15,000 datagrams; ~25 s on an idle 2-core machine.
"""

from __future__ import annotations

import dataclasses
import random
import struct
import time
from collections import Counter

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import schemas
from schemas.codec import schema_hash
from wire.telemetry.datagram import (
    CHUNK,
    MAX_FRAGMENTS,
    OVERVIEW_HASH,
    OVERVIEW_STREAM,
    TABLE_HASH,
    TABLE_STREAM,
    DatagramWriter,
    Header,
    Kind,
    StreamInfo,
    encode_overview,
    encode_stream_tables,
    fragment_count,
    fragment_length,
    new_overview,
)
from wire.telemetry.receiver import TelemetryReceiver

KEY = bytes(range(7, 39))
TYPES = {1: ("robot_state", "humanoid_league_msgs/msg/RobotControlState"),
         2: ("joint_states", "sensor_msgs/msg/JointState"),
         3: ("camera/image/compressed", "sensor_msgs/msg/CompressedImage"),
         4: ("gamestate", "humanoid_league_msgs/msg/GameState"),
         5: ("diagnostics", "diagnostic_msgs/msg/DiagnosticArray")}
STREAMS = [StreamInfo(sid, t, typ, schema_hash(typ), 1, 10.0) for sid, (t, typ) in TYPES.items()]
FUZZ_SETTINGS = settings(max_examples=1500, deadline=None, database=None,
                         suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def fresh_receiver(writer: DatagramWriter) -> TelemetryReceiver:
    # a frame's fragments may wait 30 s for each other: on a loaded machine this process can stall longer than a
    # second between two fragments, and a timed-out frame here would be the machine's fault, not the input's
    receiver = TelemetryReceiver(KEY, frame_timeout_s=30.0, max_pending_bytes=1 << 20)
    for body in encode_stream_tables(STREAMS, 100_000):
        for d in writer.message(Kind.STREAM_TABLE, TABLE_STREAM, TABLE_HASH, body):
            receiver.feed(d)
    return receiver


def check(receiver: TelemetryReceiver) -> None:
    """Bad input is counted under a known reason; nothing hit the 'internal' (unexpected exception) path."""
    assert receiver.rejected["internal"] == 0, receiver.counters()
    assert receiver.counters()["pending_bytes"] <= receiver.max_pending_bytes + CHUNK
    receiver.health()  # link health stays computable whatever came in


def valid_datagrams(writer: DatagramWriter, rng: random.Random) -> list[bytes]:
    msgs = [
        (1, schemas.make(TYPES[1][1], state=rng.randrange(15))),
        (2, schemas.make(TYPES[2][1], name=["a", "b"], position=[rng.random(), 1.0])),
        (3, schemas.make(TYPES[3][1], format="jpeg", data=np.frombuffer(rng.randbytes(3 * CHUNK), np.uint8))),
    ]
    out = [d for sid, m in msgs for d in writer.message(Kind.MESSAGE, sid, schema_hash(TYPES[sid][1]),
                                                         schemas.encode(m))]
    out += writer.message(Kind.OVERVIEW, OVERVIEW_STREAM, OVERVIEW_HASH, encode_overview(new_overview(hcm_state=3)))
    return out


def test_random_bytes_never_escape() -> None:
    total = [0]
    started = time.monotonic()

    @FUZZ_SETTINGS
    @given(st.lists(st.one_of(st.binary(max_size=1500),
                              st.binary(min_size=60, max_size=1400).map(lambda b: b"PS\x01" + b),
                              st.binary(min_size=80, max_size=200).map(lambda b: b"PS\x01\x00\x00\x00robot1" + b)),
                    min_size=15, max_size=50))
    def run(datagrams: list[bytes]) -> None:
        receiver = TelemetryReceiver(KEY)
        for d in datagrams:
            assert receiver.feed(d, ("10.0.0.1", 1)) == []
        total[0] += len(datagrams)
        check(receiver)
        assert sum(receiver.rejected.values()) == len(datagrams)

    run()
    print(f"random bytes: {total[0]} datagrams in {time.monotonic() - started:.1f} s")
    assert total[0] >= 35_000


def test_mutated_valid_datagrams_are_rejected_or_exact() -> None:
    """Bit flips, truncation, extension and splices of real datagrams: rejected, never a wrong message."""
    total = [0]
    started = time.monotonic()
    writer = DatagramWriter(KEY, "robot1")

    @FUZZ_SETTINGS
    @given(st.integers(0, 2**32 - 1), st.lists(st.tuples(st.sampled_from(["flip", "cut", "grow", "splice", "swap"]),
                                                         st.integers(0, 1399), st.integers(0, 255)),
                                               min_size=2, max_size=8))
    def run(seed: int, mutations: list[tuple[str, int, int]]) -> None:
        rng = random.Random(seed)
        receiver = fresh_receiver(writer)
        originals = valid_datagrams(writer, rng)
        fed = 0
        for base in originals:
            for kind, pos, value in mutations:
                d = bytearray(base)
                pos %= len(d)
                if kind == "flip":
                    d[pos] ^= value or 1
                elif kind == "cut":
                    del d[pos:]
                elif kind == "grow":
                    d += bytes([value]) * (pos % 64 + 1)
                elif kind == "splice":
                    other = rng.choice(originals)
                    d[pos:] = other[pos:]
                    if bytes(d) in originals:
                        continue
                else:
                    d[pos], d[-1 - pos % 8] = d[-1 - pos % 8], d[pos]
                    if bytes(d) == base:
                        continue
                assert receiver.feed(bytes(d)) == []
                fed += 1
        # the untouched originals still go through afterwards: mutations did not poison the state
        got = [m for d in originals for m in receiver.feed(d)]
        assert sorted(m.topic for m in got) == sorted(["robot_state", "joint_states", "camera/image/compressed",
                                                       "overview"])
        assert all(m.error == "" for m in got)
        total[0] += fed + len(originals)
        check(receiver)

    run()
    print(f"mutations: {total[0]} datagrams in {time.monotonic() - started:.1f} s")
    assert total[0] >= 50_000


SAMPLES = {1: schemas.encode(schemas.make(TYPES[1][1], state=3)),
           2: schemas.encode(schemas.make(TYPES[2][1], name=["a", "b"], position=[0.5, 1.0])),
           4: schemas.encode(schemas.make(TYPES[4][1], game_state=3, coach_message="go")),
           5: schemas.encode(schemas.make(TYPES[5][1]))}
COHERENT = [(Kind.MESSAGE, s.stream_id, s.schema_hash) for s in STREAMS] + [
    (Kind.OVERVIEW, OVERVIEW_STREAM, OVERVIEW_HASH), (Kind.STREAM_TABLE, TABLE_STREAM, TABLE_HASH)]


@st.composite
def authentic_header(draw: st.DrawFn) -> tuple[Header, bytes]:
    """Half coherent (kind, stream and schema agree, sizes plausible), half anything the fields can hold."""
    if draw(st.booleans()):
        kind, stream, schema = draw(st.sampled_from(COHERENT))
        size = 64 if kind == Kind.OVERVIEW else draw(st.one_of(st.integers(0, 80), st.integers(0, 3 * CHUNK)))
    else:
        kind = draw(st.sampled_from(list(Kind)))
        stream = draw(st.integers(0, 0xFFFF))
        schema = draw(st.integers(0, 2**32 - 1))
        size = draw(st.integers(0, CHUNK * MAX_FRAGMENTS))
    count = fragment_count(size)
    if draw(st.integers(0, 4)) == 0:
        count = draw(st.integers(1, 0xFFFF))
    index = draw(st.integers(0, max(0, min(count, 5) - 1)))
    length = fragment_length(size, index, count)
    if draw(st.integers(0, 4)) == 0 or not 0 <= length <= CHUNK:
        length = draw(st.integers(0, CHUNK))
    # the decoders branch on the first bytes (CDR encapsulation, lengths): those come from hypothesis, the rest
    # from a drawn seed, which keeps generation fast for 1,320-byte bodies
    prefix = draw(st.one_of(st.binary(max_size=24), st.binary(max_size=20).map(lambda b: b"\0\1\0\0" + b)))
    prefix = prefix[:length]
    body = prefix + random.Random(draw(st.integers(0, 2**32 - 1))).randbytes(length - len(prefix))
    if kind == Kind.MESSAGE and stream in SAMPLES and draw(st.integers(0, 3)) == 0:
        # a real message with one byte changed: mostly still decodes, to another value or not at all
        real = bytearray(SAMPLES[stream])
        real[draw(st.integers(0, len(real) - 1))] = draw(st.integers(0, 255))
        body, size, count, index = bytes(real), len(real), fragment_count(len(real)), 0
        if count > 1:
            body = body[:CHUNK]
    header = Header(kind, "robot1", stream, schema, 1, draw(st.integers(0, 2**32 - 1)), time.time_ns(),
                    draw(st.integers(0, 3)), size, index, count, draw(st.booleans()))
    return header, body


def test_authentic_garbage_reaches_the_deep_decoders() -> None:
    """Datagrams sealed with the right key but arbitrary fields and bodies: tables, overviews, fragments, CDR."""
    total = [0]
    started = time.monotonic()
    writer = DatagramWriter(KEY, "robot1", boot_id=1)
    reached: Counter[str] = Counter()

    @settings(FUZZ_SETTINGS, max_examples=500)
    @given(st.lists(authentic_header(), min_size=10, max_size=30))
    def run(items: list[tuple[Header, bytes]]) -> None:
        receiver = fresh_receiver(writer)
        datagrams = []
        for header, body in items:
            datagrams.append((header, body))
            # the frame's other fragments, well sized, so garbage frames complete and reach the CDR decoder
            for k in range(min(header.fragment_count, 5)):
                if k != header.fragment_index and header.frame_size - CHUNK * k >= 0:
                    size = fragment_length(header.frame_size, k, header.fragment_count)
                    filler = random.Random(header.seq + k).randbytes(max(0, min(size, CHUNK)))
                    datagrams.append((dataclasses.replace(header, fragment_index=k, seq=header.seq + k + 1), filler))
        for header, body in datagrams:
            try:
                d = writer.sealer.seal(header, body)
            except (ValueError, struct.error):  # larger than a datagram or a field: the sender can't make it
                continue
            for m in receiver.feed(d):
                assert m.robot_id == "robot1"
                assert m.topic in {"overview"} | {s.topic for s in STREAMS}
                assert (m.msg is None) == bool(m.error)
                reached["overview" if m.topic == "overview" else "undecodable" if m.error else "decoded"] += 1
            total[0] += 1
        check(receiver)

    run()
    print(f"authentic garbage: {total[0]} datagrams in {time.monotonic() - started:.1f} s, {dict(reached)}")
    assert total[0] >= 15_000
    assert min(reached[k] for k in ("overview", "decoded", "undecodable")) > 0  # the deep paths were reached
