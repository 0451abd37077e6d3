"""The telemetry datagram format and the receiver's checks: round trips, layout, size, auth, replays."""

from __future__ import annotations

import asyncio
import os
import socket
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import schemas
from robot_nodes.telemetry.budget import ByteBudget, Frame, Stream
from robot_nodes.telemetry.sender import parse_destination, parse_topics
from schemas.codec import schema_hash
from schemas.topics import Priority
from wire.telemetry.datagram import (
    CHUNK,
    DEV_KEY,
    HEADER_SIZE,
    MAX_DATAGRAM,
    OVERVIEW_HASH,
    OVERVIEW_STREAM,
    TABLE_HASH,
    TABLE_STREAM,
    TAG_SIZE,
    DatagramWriter,
    Header,
    Kind,
    Sealer,
    StreamInfo,
    TelemetryError,
    decode_stream_table,
    encode_overview,
    encode_stream_tables,
    load_key,
    new_overview,
    parse_header,
)
from wire.telemetry.receiver import TelemetryReceiver

KEY = bytes(range(32))
IMAGE_TYPE = "sensor_msgs/msg/CompressedImage"
STATE_TYPE = "humanoid_league_msgs/msg/RobotControlState"
STREAMS = [StreamInfo(1, "robot_state", STATE_TYPE, schema_hash(STATE_TYPE), 0, 10.0),
           StreamInfo(2, "camera/image/compressed", IMAGE_TYPE, schema_hash(IMAGE_TYPE), 3, 2.0)]


def table(writer: DatagramWriter, streams: list[StreamInfo] = STREAMS) -> list[bytes]:
    return [d for body in encode_stream_tables(streams, 200_000)
            for d in writer.message(Kind.STREAM_TABLE, TABLE_STREAM, TABLE_HASH, body)]


def image_msg(n_bytes: int, seed: int = 0) -> object:
    data = np.random.default_rng(seed).integers(0, 256, n_bytes, dtype=np.uint8)
    return schemas.make(IMAGE_TYPE, format="jpeg", data=data)


def feed_all(receiver: TelemetryReceiver, datagrams: list[bytes]) -> list:
    return [m for d in datagrams for m in receiver.feed(d, ("127.0.0.1", 9))]


@pytest.mark.parametrize("encrypt", [True, False])
def test_message_round_trip_through_fragments(encrypt: bool) -> None:
    writer = DatagramWriter(KEY, "robot7", encrypt=encrypt)
    receiver = TelemetryReceiver(KEY)
    msg = image_msg(10 * CHUNK + 17)
    payload = schemas.encode(msg)
    datagrams = writer.message(Kind.MESSAGE, 2, schema_hash(IMAGE_TYPE), payload)
    assert len(datagrams) == 11
    assert all(len(d) <= MAX_DATAGRAM for d in datagrams)
    assert feed_all(receiver, table(writer)) == []
    (got,) = feed_all(receiver, datagrams)
    assert (got.robot_id, got.topic, got.type, got.error) == ("robot7", "camera/image/compressed", IMAGE_TYPE, "")
    assert got.payload == payload
    assert bytes(got.msg.data) == bytes(msg.data)
    assert abs(got.receive_time - got.send_time) < 5
    # the clear mode carries the payload readable; the encrypted mode does not
    assert (payload[:CHUNK] in datagrams[0]) is (not encrypt)


def test_header_layout_is_the_documented_one() -> None:
    writer = DatagramWriter(KEY, "robot1", encrypt=False, boot_id=0xA1B2C3D4, clock_ns=lambda: 1_700_000_000_123)
    (d,) = writer.message(Kind.MESSAGE, 3, 0xDEADBEEF, b"hello")
    assert HEADER_SIZE == 64 and len(d) == 64 + 5 + TAG_SIZE
    assert d[0:2] == b"PS" and d[2] == 1 and d[3] == 0 and d[4] == 0 and d[5] == 0
    assert d[6:18] == b"robot1" + b"\0" * 6
    assert struct.unpack_from("<HIIIqIIHH", d, 18) == (3, 0xDEADBEEF, 0xA1B2C3D4, 0, 1_700_000_000_123, 0, 5, 0, 1)
    assert d[64:69] == b"hello"
    h = parse_header(d)
    assert (h.robot_id, h.stream_id, h.seq, h.frame_id, h.encrypted) == ("robot1", 3, 0, 0, False)
    d2 = writer.message(Kind.MESSAGE, 3, 0xDEADBEEF, b"again")[0]
    assert struct.unpack_from("<I", d2, 28)[0] == 1  # sequence per stream
    assert struct.unpack_from("<I", d2, 40)[0] == 1  # frame id per stream
    assert d2[52:64] != d[52:64]  # fresh nonce


def test_max_size_every_datagram_fits() -> None:
    writer = DatagramWriter(KEY, "r1")
    for size in (0, 1, CHUNK - 1, CHUNK, CHUNK + 1, 3 * CHUNK, 200_000):
        datagrams = writer.message(Kind.MESSAGE, 1, 1, os.urandom(size))
        assert max(len(d) for d in datagrams) <= MAX_DATAGRAM
        assert len(datagrams) == max(1, -(-size // CHUNK))
    assert len(writer.message(Kind.MESSAGE, 1, 1, b"x" * CHUNK)[0]) == MAX_DATAGRAM


def test_overview_round_trip() -> None:
    writer = DatagramWriter(KEY, "robot2")
    receiver = TelemetryReceiver(KEY)
    overview = new_overview(hcm_state=10, game_state=3, penalized=True, pose_known=True, pose_x=-2.5,
                            pose_y=1.25, pose_theta=0.5, pose_confidence=0.75, ball_known=True, ball_x=0.5,
                            battery_voltage=12.25, hottest_servo="RKnee", hottest_servo_temperature=61.5,
                            own_score=2, rival_score=1, seconds_remaining=-12, pose_age_ms=40)
    body = encode_overview(overview)
    assert len(body) == 64
    (d,) = writer.message(Kind.OVERVIEW, OVERVIEW_STREAM, OVERVIEW_HASH, body)
    assert len(d) == 64 + 64 + 16
    (got,) = receiver.feed(d)  # the overview needs no stream table: a late receiver has it at once
    assert got.topic == "overview" and got.msg == overview
    assert schemas.to_dict(got.msg)["hcm_state"] == 10


def test_stream_table_round_trip_and_split() -> None:
    many = [StreamInfo(i, f"topic/number/{i:04d}", "sensor_msgs/msg/JointState", i * 7, i % 4, 2.5)
            for i in range(1, 120)]
    bodies = encode_stream_tables(many, 123_456)
    assert len(bodies) > 1 and all(len(b) <= CHUNK for b in bodies)
    decoded = [s for b in bodies for s in decode_stream_table(b)[1]]
    assert decoded == many
    assert decode_stream_table(bodies[0])[0] == 123_456
    with pytest.raises(TelemetryError):
        decode_stream_table(bodies[0][:-1])


def test_forged_datagrams_are_rejected_and_counted() -> None:
    receiver = TelemetryReceiver(KEY)
    writer = DatagramWriter(KEY, "robot1")
    forger = DatagramWriter(os.urandom(32), "robot1")
    feed_all(receiver, table(writer))
    good = writer.message(Kind.MESSAGE, 1, schema_hash(STATE_TYPE), schemas.encode(schemas.make(STATE_TYPE, state=2)))
    assert len(feed_all(receiver, good)) == 1
    forged = forger.message(Kind.MESSAGE, 1, schema_hash(STATE_TYPE), b"\0\1\0\0\3")
    assert feed_all(receiver, forged) == []
    # flip one bit anywhere (header or body): never accepted
    flipped = 0
    for pos in range(0, len(good[0])):
        d = bytearray(writer.message(Kind.MESSAGE, 1, schema_hash(STATE_TYPE), b"\0\1\0\0\3")[0])
        d[pos] ^= 0x10
        flipped += receiver.feed(bytes(d)) == []
    assert flipped == len(good[0])
    assert sum(receiver.rejected.values()) == flipped + 1  # + the forged one
    assert receiver.rejected["auth_failed"] >= 40  # the rest fail the shape checks before the tag
    assert receiver.rejected["bad_magic"] >= 1
    assert receiver.messages == 1


def test_robot_id_inside_the_authenticated_header() -> None:
    """With per-robot keys, robot2 cannot speak as robot1; a rewritten robot id breaks the tag."""
    key1, key2 = os.urandom(32), os.urandom(32)
    receiver = TelemetryReceiver(KEY, robot_keys={"robot1": key1, "robot2": key2})
    impostor = DatagramWriter(key2, "robot1")
    assert receiver.feed(impostor.message(Kind.OVERVIEW, OVERVIEW_STREAM, OVERVIEW_HASH,
                                          encode_overview(new_overview()))[0]) == []
    honest = DatagramWriter(key2, "robot2").message(Kind.OVERVIEW, OVERVIEW_STREAM, OVERVIEW_HASH,
                                                     encode_overview(new_overview()))[0]
    relabelled = honest[:6] + b"robot1\0\0\0\0\0\0" + honest[18:]
    assert receiver.feed(relabelled) == []
    assert receiver.rejected["auth_failed"] == 2
    assert len(receiver.feed(honest)) == 1
    only_ours = TelemetryReceiver(key2, robots=["robot1"])
    assert only_ours.feed(honest) == [] and only_ours.rejected["unknown_robot"] == 1


def test_replayed_datagrams_are_rejected() -> None:
    now = [1_700_000_000.0]
    receiver = TelemetryReceiver(KEY, clock=lambda: now[0])
    writer = DatagramWriter(KEY, "robot1", clock_ns=lambda: int(now[0] * 1e9))
    body = encode_overview(new_overview())
    first = writer.message(Kind.OVERVIEW, OVERVIEW_STREAM, OVERVIEW_HASH, body)[0]
    assert len(receiver.feed(first)) == 1
    assert receiver.feed(first) == []  # exact duplicate
    later = [writer.message(Kind.OVERVIEW, OVERVIEW_STREAM, OVERVIEW_HASH, body)[0] for _ in range(5)]
    assert len(feed_all(receiver, later[::-1])) == 5  # reordered, not replayed: all accepted
    assert feed_all(receiver, later) == []
    now[0] += 30.0
    fresh = writer.message(Kind.OVERVIEW, OVERVIEW_STREAM, OVERVIEW_HASH, body)[0]
    assert len(receiver.feed(fresh)) == 1
    # an old datagram of a previous sender boot (new boot id, old time) is a replay too
    old_boot = DatagramWriter(KEY, "robot1", clock_ns=lambda: int((now[0] - 20) * 1e9))
    assert receiver.feed(old_boot.message(Kind.OVERVIEW, OVERVIEW_STREAM, OVERVIEW_HASH, body)[0]) == []
    assert receiver.rejected["replay"] == 7
    # a restarted sender (new boot, newer time) is accepted although its sequence starts at 0 again
    now[0] += 1.0
    restarted = DatagramWriter(KEY, "robot1", clock_ns=lambda: int(now[0] * 1e9))
    assert len(receiver.feed(restarted.message(Kind.OVERVIEW, OVERVIEW_STREAM, OVERVIEW_HASH, body)[0])) == 1
    # the robot's clock steps back a minute (NTP): within a boot the sequence decides, nothing is lost
    now[0] -= 60.0
    assert len(receiver.feed(restarted.message(Kind.OVERVIEW, OVERVIEW_STREAM, OVERVIEW_HASH, body)[0])) == 1
    # a restart with the clock behind the previous run is refused until the receiver forgets the robot
    behind = DatagramWriter(KEY, "robot1", clock_ns=lambda: int(now[0] * 1e9))
    assert receiver.feed(behind.message(Kind.OVERVIEW, OVERVIEW_STREAM, OVERVIEW_HASH, body)[0]) == []
    receiver.forget("robot1")
    assert len(receiver.feed(behind.message(Kind.OVERVIEW, OVERVIEW_STREAM, OVERVIEW_HASH, body)[0])) == 1


def test_fragments_of_different_frames_never_mix_and_loss_is_counted() -> None:
    now = [100.0]
    receiver = TelemetryReceiver(KEY, frame_timeout_s=1.0, clock=lambda: now[0])
    writer = DatagramWriter(KEY, "robot1")
    feed_all(receiver, table(writer))
    a = writer.message(Kind.MESSAGE, 2, schema_hash(IMAGE_TYPE), schemas.encode(image_msg(5 * CHUNK, 1)))
    b = writer.message(Kind.MESSAGE, 2, schema_hash(IMAGE_TYPE), schemas.encode(image_msg(5 * CHUNK, 2)))
    # lose a[2]; interleave the rest
    got = feed_all(receiver, [a[0], b[0], a[1], b[1], b[2], a[3], b[3], b[4], a[4], b[5], a[5]])
    assert len(got) == 1 and bytes(got[0].msg.data) == bytes(image_msg(5 * CHUNK, 2).data)
    now[0] += 2.0
    assert receiver.expire() == 1 and receiver.frames_dropped["incomplete"] == 1
    health = receiver.health()["robot1"]
    image = next(s for s in health.streams if s.topic == "camera/image/compressed")
    assert image.lost == 1 and image.messages == 1 and image.loss_pct > 0


def test_header_shape_errors() -> None:
    sealer = Sealer(KEY)
    ok = Header(Kind.MESSAGE, "robot1", 1, 1, 1, 0, 0, 0, 10, 0, 1, False)
    d = sealer.seal(ok, b"0123456789")
    cases = {
        "malformed": [d[:40], d + b"x" * 2000, d[:4] + b"\x07" + d[5:]],
        "bad_magic": [b"XX" + d[2:]],
        "bad_version": [d[:2] + b"\x09" + d[3:]],
        "bad_fragment": [sealer.seal(Header(Kind.MESSAGE, "robot1", 1, 1, 1, 0, 0, 0, 10, 0, 2, False), b"0" * 10)],
    }
    for reason, datagrams in cases.items():
        for datagram in datagrams:
            with pytest.raises(TelemetryError) as err:
                sealer.open(datagram)
            assert err.value.reason == reason
    with pytest.raises(TelemetryError) as err:
        sealer.open(sealer.seal(ok, b"short"))
    assert err.value.reason == "bad_fragment"


def test_keys_and_parameters_parse() -> None:
    assert load_key(KEY.hex()) == KEY
    assert load_key("") == DEV_KEY
    with pytest.raises(ValueError):
        load_key("not-a-key-nor-a-file")
    assert parse_topics("robot_state:10, camera/image/compressed:0.5") == {"robot_state": 10.0,
                                                                         "camera/image/compressed": 0.5}
    with pytest.raises(ValueError, match="no_such_topic"):
        parse_topics("no_such_topic:3")
    assert parse_destination("10.0.0.2:5900") == ("10.0.0.2", 5900)
    assert parse_destination("[::1]:5801") == ("::1", 5801)
    with pytest.raises(ValueError):
        parse_destination("host:notaport")


def test_budget_shares_bytes_by_priority() -> None:
    """With a saturating image stream, state streams still get all they ask for."""
    t = [0.0]
    budget = ByteBudget(50_000, clock=lambda: t[0])
    sent: dict[str, int] = {"image": 0, "state": 0}

    def send(stream: Stream, frame: Frame, index: int) -> int:
        size = HEADER_SIZE + len(frame.fragments[index]) + TAG_SIZE
        sent[stream.key] += size
        return size

    offered_state = 0
    for step in range(1000):  # 10 s at 100 Hz
        t[0] += 0.01
        if step % 2 == 0:
            budget.offer("image", Priority.BULK, lambda: b"i" * 60_000)
        if step % 5 == 0:
            budget.offer("state", Priority.CRITICAL, lambda: b"s" * 300)
            offered_state += 1
        budget.pump(send)
    total = sent["image"] + sent["state"]
    assert 0.9 * 500_000 <= total <= 1.1 * 500_000
    assert sent["state"] >= 0.95 * offered_state * 380


def test_dry_run_estimates_what_the_budget_grants() -> None:
    from robot_nodes.telemetry.estimate import estimate_bandwidth

    default = estimate_bandwidth({})
    assert 0 < default["total"] < 200_000
    assert default["overview"] == pytest.approx(10 * (64 + 64 + 16))
    tight = estimate_bandwidth({"image_max_width": 0, "budget_bytes_per_s": 50_000})
    assert tight["total"] == pytest.approx(50_000, rel=0.01)
    for name in ("robot_state", "gamestate", "joint_states", "overview"):
        assert tight[name] == pytest.approx(default[name])  # state keeps all it asks for
    assert tight["camera/image/compressed"] < default["camera/image/compressed"] * 5
    with pytest.raises(ValueError, match="no_such"):
        estimate_bandwidth({"no_such": 1})


def test_dry_run_cli(tmp_path: Path) -> None:
    params = tmp_path / "params.yaml"
    params.write_text("telemetry:\n  topics: robot_state:10,camera/image/compressed:1\n  budget_bytes_per_s: 30000\n")
    out = subprocess.run([sys.executable, "-m", "robot_nodes.telemetry", "--dry-run", "--config", str(params)],
                         capture_output=True, text=True, timeout=60, check=True).stdout
    assert "robot_state" in out and "camera/image/compressed" in out and "budget 30000" in out
    assert "joint_states" not in out


def test_asyncio_listener_delivers_whole_messages() -> None:
    from wire.telemetry.receiver import listen

    async def scenario() -> list:
        receiver = TelemetryReceiver(KEY)
        got: list = []
        arrived = asyncio.Event()

        def on_messages(messages: list) -> None:
            got.extend(messages)
            arrived.set()

        transport = await listen(receiver, on_messages, host="127.0.0.1", port=0)
        try:
            port = transport.get_extra_info("sockname")[1]
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
                for d in DatagramWriter(KEY, "robot5").message(Kind.OVERVIEW, OVERVIEW_STREAM, OVERVIEW_HASH,
                                                               encode_overview(new_overview(hcm_state=2))):
                    s.sendto(d, ("127.0.0.1", port))
                s.sendto(b"garbage", ("127.0.0.1", port))
            await asyncio.wait_for(arrived.wait(), 10)
        finally:
            transport.close()
        return got

    (message,) = asyncio.run(scenario())
    assert (message.robot_id, message.topic, message.msg.hcm_state) == ("robot5", "overview", 2)
