"""MCAP logs: pitchside logs open in plain mcap tools, real ROS 2 bags open in pitchside,
cut-off logs keep every complete chunk, bookmarks, rotation and seeking."""

from __future__ import annotations

import dataclasses
import logging
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

import schemas
from schemas.logs import BOOKMARK_TOPIC, LogError, LogReader, LogSeriesReader, LogWriter, log_series

REPO = Path(__file__).resolve().parents[1]
T0 = 1_700_000_000_000_000_000


def joint_state(i: int) -> Any:
    return schemas.make(
        "sensor_msgs/msg/JointState",
        header=schemas.make("std_msgs/msg/Header", frame_id=f"base_{i}",
                            stamp=schemas.make("builtin_interfaces/msg/Time", sec=i, nanosec=7 * i)),
        name=["HeadPan", "HeadTilt", "LKnee"],
        position=[0.1 * i, -0.2, 1.5],
        velocity=[float(i), 0.0, -1.0],
        effort=[],
    )


def mixed_messages(n: int) -> list[tuple[str, str, Any, int]]:
    """(robot, topic, message, log time) of several robots, topics and types, in time order."""
    out: list[tuple[str, str, Any, int]] = []
    for i in range(n):
        t = T0 + i * 10_000_000
        robot = f"robot{1 + i % 3}"
        out.append((robot, "joint_states", joint_state(i), t))
        if i % 4 == 0:
            out.append((robot, "gamestate", schemas.make(
                "humanoid_league_msgs/msg/GameState", own_score=i % 5, rival_score=2, seconds_remaining=600 - i,
                coach_message=f"press {i}", team_mates_with_penalty=[1, 0, 1]), t + 1))
        if i % 5 == 0:
            out.append((robot, "cmd_vel", schemas.make(
                "geometry_msgs/msg/Twist", linear=schemas.make("geometry_msgs/msg/Vector3", x=0.05 * i),
                angular=schemas.make("geometry_msgs/msg/Vector3", z=-0.3)), t + 2))
        if i % 7 == 0:
            out.append((robot, "paused", schemas.make("std_msgs/msg/Bool", data=i % 2 == 0), t + 3))
    return out


def write_log(path: Path, messages: list[tuple[str, str, Any, int]], **options: Any) -> None:
    with LogWriter(path, **options) as writer:
        for robot, topic, msg, t in messages:
            writer.write(robot, topic, msg, log_time_ns=t)


def assert_same(ours: Any, theirs: Any, where: str = "msg") -> None:
    """A rosbags message equals what mcap-ros2-support decoded, field by field."""
    if dataclasses.is_dataclass(ours):
        for field in dataclasses.fields(ours):
            if field.name != "__msgtype__" and not field.name.isupper():  # constants are class-level in ROS
                assert_same(getattr(ours, field.name), getattr(theirs, field.name), f"{where}.{field.name}")
    elif isinstance(ours, np.ndarray):
        theirs_array = np.frombuffer(theirs, np.uint8) if isinstance(theirs, bytes) else np.asarray(theirs)
        np.testing.assert_array_equal(ours, theirs_array, err_msg=where)
    elif isinstance(ours, list):
        assert len(ours) == len(theirs), where
        for k, (a, b) in enumerate(zip(ours, theirs, strict=True)):
            assert_same(a, b, f"{where}[{k}]")
    else:
        assert ours == theirs, f"{where}: {ours!r} != {theirs!r}"


# -- (a) pitchside logs in the plain mcap tools ---------------------------------------------------------


def test_pitchside_log_decodes_with_plain_mcap_ros2(tmp_path: Path) -> None:
    messages = mixed_messages(60)
    path = tmp_path / "match.mcap"
    write_log(path, messages, chunk_size=4096)

    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        assert summary.statistics.message_count == len(messages)
        assert len(summary.chunk_indexes) > 3
        assert all(index.message_index_offsets for index in summary.chunk_indexes)
        assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"}
        assert {c.message_encoding for c in summary.channels.values()} == {"cdr"}
        decoded = list(reader.iter_decoded_messages())

    assert len(decoded) == len(messages)
    for (robot, topic, msg, t), (schema, channel, message, theirs) in zip(messages, decoded, strict=True):
        assert channel.topic == f"/{robot}/{topic}"
        assert channel.metadata == {"robot_id": robot, "topic": topic}
        assert schema is not None and schema.name == msg.__msgtype__
        assert schema.data.decode() == schemas.msgdef(msg.__msgtype__)
        assert message.log_time == t
        assert_same(msg, theirs)


def test_pitchside_log_reads_with_rosbags_anyreader(tmp_path: Path) -> None:
    """The ROS 2 side: rosbags (as `ros2 bag` would) reads the bare file, our own types included."""
    from rosbags.highlevel import AnyReader

    messages = mixed_messages(20)
    path = tmp_path / "for_ros.mcap"
    write_log(path, messages)
    with AnyReader([path]) as reader:
        got = [(c.topic, t, reader.deserialize(raw, c.msgtype)) for c, t, raw in reader.messages()]
    assert [(topic, t) for topic, t, _ in got] == [(f"/{r}/{topic}", t) for r, topic, _, t in messages]
    games = [(msg, theirs) for (_, topic, msg, _), (_, _, theirs) in zip(messages, got, strict=True)
             if topic == "gamestate"]
    assert games and all(ours.coach_message == theirs.coach_message for ours, theirs in games)
    assert all(list(ours.team_mates_with_penalty) == list(theirs.team_mates_with_penalty) for ours, theirs in games)


def test_cdr_bytes_take_their_type_from_the_topic_table(tmp_path: Path) -> None:
    path = tmp_path / "bytes.mcap"
    state = schemas.make("humanoid_league_msgs/msg/RobotControlState", state=3)
    with LogWriter(path) as writer:
        writer.write("robot1", "robot_state", schemas.encode(state), log_time_ns=T0)
        with pytest.raises(LogError, match="typename"):
            writer.write("robot1", "no_such_topic", b"\x00\x01\x00\x00")
        with pytest.raises(LogError, match="not a message"):
            writer.write("robot1", "robot_state", 42)
    with LogReader(path) as reader:
        (item,) = list(reader.messages())
    assert item.typename == "humanoid_league_msgs/msg/RobotControlState"
    assert item.msg.state == 3 and not item.raw


# -- (b) real ROS 2 bags made by others ------------------------------------------------------------------


def test_talker_bag_reads_with_decoded_strings_and_logs(testdata: Path) -> None:
    with LogReader(testdata / "mcap" / "talker.mcap") as reader:
        assert reader.indexed and not reader.warnings
        assert reader.topics == {"parameter_events": "rcl_interfaces/msg/ParameterEvent",
                                   "rosout": "rcl_interfaces/msg/Log", "topic": "std_msgs/msg/String"}
        counts = {c.topic: c.message_count for c in reader.channels}
        assert counts == {"parameter_events": 0, "rosout": 10, "topic": 10}
        assert reader.robots == [""]
        assert reader.start_ns == 1585866235112411371 and reader.end_ns == 1585866239643508139
        assert reader.duration == pytest.approx(4.531, abs=0.001)
        strings = [m.msg.data for m in reader.messages(topics=["topic"])]
        logs = list(reader.messages(topics=["/rosout"]))
    assert strings == [f"Hello, world! {i}" for i in range(10)]
    assert len(logs) == 10 and all(not m.raw for m in logs)
    assert logs[0].msg.level == 20 and logs[0].msg.stamp.sec == 1585866235
    assert "Hello, world! 0" in logs[0].msg.msg


def test_cdr_test_bag_decodes_basic_types_and_arrays(testdata: Path) -> None:
    with LogReader(testdata / "mcap" / "cdr_test_0.mcap") as reader:
        assert {c.topic: c.message_count for c in reader.channels} == {"test_topic": 3, "array_topic": 4}
        basics = list(reader.messages(topics=["test_topic"]))
        arrays = list(reader.messages(topics=["array_topic"]))
        everything = list(reader.messages())
    assert [m.typename for m in basics] == ["test_msgs/msg/BasicTypes"] * 3
    assert all(m.msg.int32_value == 123 and m.msg.bool_value is False for m in basics)
    assert all(list(m.msg.string_values) == ["Complex Hello1", "Complex Hello2", "Complex Hello3"] for m in arrays)
    assert list(arrays[0].msg.bool_values) == [True, False, True]
    times = [m.log_time_ns for m in everything]
    assert len(times) == 7 and times == sorted(times)


def test_service_event_channels_yield_raw_bytes(testdata: Path) -> None:
    with LogReader(testdata / "mcap" / "bag_with_topics_and_service_events.mcap") as reader:
        channels = {c.topic: c for c in reader.channels}
        assert {t: c.message_count for t, c in channels.items()} == {
            "test_topic1": 1, "test_topic2": 1, "test_service1/_service_event": 4,
            "test_service2/_service_event": 4, "events/write_split": 0}
        service = channels["test_service1/_service_event"]
        assert not service.decodable and "BasicTypes_Event" in service.problem
        assert channels["test_topic1"].decodable
        items = list(reader.messages())
        assert reader.bookmarks == []  # its two "rosbag2" metadata records are not bookmarks
    raw = [m for m in items if m.raw]
    assert len(items) == 10 and len(raw) == 8
    assert all(isinstance(m.msg, bytes) and m.topic.endswith("_service_event") for m in raw)
    strings = [m.msg for m in items if m.topic == "test_topic1"]
    assert strings[0].string_value_default1 == "Hello world!"
    assert strings[0].bounded_string_value_default3 == 'Hello"world!'


def test_every_shared_mcap_file_reads_completely(testdata: Path) -> None:
    files = sorted((testdata / "mcap").glob("*.mcap"))
    assert len(files) >= 3
    for path in files:
        with LogReader(path) as reader:
            total = sum(c.message_count for c in reader.channels)
            assert len(list(reader.messages())) == total == reader.message_count, path.name
            assert len(list(reader.messages(decode=False))) == total


# -- (c) logs cut off by a crash --------------------------------------------------------------------------


def test_truncated_log_keeps_every_complete_chunk(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    messages = mixed_messages(120)
    path = tmp_path / "crash.mcap"
    with LogWriter(path, chunk_size=3000, compression="zstd") as writer:
        for robot, topic, msg, t in messages:
            writer.write(robot, topic, msg, log_time_ns=t)
            if t == messages[10][3]:
                writer.add_bookmark("kickoff", t, {"half": 1})
    with open(path, "rb") as f:
        chunks = sorted(make_reader(f).get_summary().chunk_indexes, key=lambda c: c.chunk_start_offset)
    assert len(chunks) >= 6
    k = len(chunks) // 2
    cut = chunks[k].chunk_start_offset + chunks[k].chunk_length // 2
    expected = [m for m in messages if m[3] <= chunks[k - 1].message_end_time]
    assert 0 < len(expected) < len(messages)
    cut_path = tmp_path / "cut.mcap"
    cut_path.write_bytes(path.read_bytes()[:cut])

    progress: list[float] = []
    with caplog.at_level(logging.WARNING), LogReader(cut_path, on_progress=progress.append) as reader:
        assert not reader.indexed
        assert len(reader.warnings) == 1 and "cut inside a chunk record" in reader.warnings[0]
        items = list(reader.messages())
        marks = reader.bookmarks
        counted = sum(c.message_count for c in reader.channels)
        assert reader.end_ns == expected[-1][3]
    assert "cut inside a chunk record" in caplog.text
    assert [(m.robot_id, m.topic, m.log_time_ns) for m in items] == [(r, t, ts) for r, t, _, ts in expected]
    assert counted == len(expected)
    for item, (_, _, msg, _) in zip(items, expected, strict=True):
        assert_same(msg, item.msg)
    assert [(b.name, b.data) for b in marks] == [("kickoff", {"half": 1})]
    assert progress[-1] == 1.0 and progress == sorted(progress)


def test_crashed_writer_process_loses_at_most_the_open_chunk(tmp_path: Path) -> None:
    path = tmp_path / "killed.mcap"
    script = textwrap.dedent(f"""
        import os, sys
        import schemas
        from schemas.logs import LogWriter
        writer = LogWriter({str(path)!r}, chunk_size=2000, flush_interval_s=None)
        for i in range(500):
            msg = schemas.make("std_msgs/msg/String", data=f"message {{i}}")
            writer.write("robot1", "speak_log", msg, log_time_ns={T0} + i)
        sys.stdout.flush()
        os._exit(3)  # no close(): no summary, no footer, the open chunk is never written
    """)
    done = subprocess.run([sys.executable, "-c", script], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert done.returncode == 3, done.stderr
    with LogReader(path) as reader:
        texts = [m.msg.data for m in reader.messages()]
        assert reader.warnings and "without a footer" in reader.warnings[0]
    per_chunk = 2000 // 40 + 1  # a chunk closes once it passes 2000 bytes; a message record is >= 40 bytes
    assert texts == [f"message {i}" for i in range(len(texts))]
    assert 500 - per_chunk <= len(texts) < 500


def test_a_log_continued_after_a_crash_reads_back_as_one_series(tmp_path: Path) -> None:
    path = tmp_path / "game.mcap"
    cut = LogWriter(path, chunk_size=500, rotate_bytes=4000, flush_interval_s=None)
    for i in range(60):
        cut.write("robot1", "joint_states", joint_state(i), log_time_ns=T0 + i)
    cut.flush()  # then the process dies: no close, no summary
    assert [p.name for p in cut.paths][:2] == ["game.mcap", "game_001.mcap"]
    with LogWriter(path, continue_series=True) as resumed:
        for i in range(60, 70):
            resumed.write("robot1", "joint_states", joint_state(i), log_time_ns=T0 + i)
    assert resumed.paths == [path.with_name(f"game_{len(cut.paths):03d}.mcap")]  # after the last file, none overwritten
    with LogSeriesReader(path) as series:
        assert [m.msg.header.frame_id for m in series.messages()] == [f"base_{i}" for i in range(70)]


def test_not_an_mcap_file_is_a_clear_error(tmp_path: Path) -> None:
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"this is not a log")
    with pytest.raises(LogError, match="not an MCAP file"):
        LogReader(junk)
    with pytest.raises(LogError, match="cannot open"):
        LogReader(tmp_path / "missing.mcap")


@pytest.fixture(scope="module")
def small_log(tmp_path_factory: pytest.TempPathFactory) -> bytes:
    path = tmp_path_factory.mktemp("fuzz") / "small.mcap"
    write_log(path, mixed_messages(12), chunk_size=500, compression="none")
    return path.read_bytes()


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_damaged_logs_never_crash_the_reader(tmp_path: Path, small_log: bytes, data: st.DataObject) -> None:
    blob = bytearray(small_log[: data.draw(st.integers(8, len(small_log)), label="cut")])
    for _ in range(data.draw(st.integers(0, 4), label="flips")):
        blob[data.draw(st.integers(0, len(blob) - 1))] ^= data.draw(st.integers(1, 255))
    path = tmp_path / "damaged.mcap"
    path.write_bytes(bytes(blob))
    try:
        reader = LogReader(path)
    except LogError:
        return
    with reader:
        channels = reader.channels
        items = list(reader.messages())
        marks = reader.bookmarks
    assert len(items) <= 40 and len(channels) <= 40 and len(marks) <= 40


# -- (d) bookmarks ---------------------------------------------------------------------------------------


def test_bookmarks_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "marks.mcap"
    messages = mixed_messages(30)
    with LogWriter(path, chunk_size=2048) as writer:
        for i, (robot, topic, msg, t) in enumerate(messages):
            writer.write(robot, topic, msg, log_time_ns=t)
            if i == 5:
                writer.add_bookmark("goal", t, {"team": "blue", "score": [1, 0]})
        writer.add_bookmark("fall", messages[2][3] + 5, {"robot": "robot2"})
        with pytest.raises(LogError, match="JSON"):
            writer.add_bookmark("bad", T0, {"x": object()})
    with LogReader(path) as reader:
        marks = reader.bookmarks
        assert BOOKMARK_TOPIC not in reader.topics
        assert len(list(reader.messages())) == len(messages)
        assert len(list(reader.messages(topics=[BOOKMARK_TOPIC]))) == 2
    assert [(b.name, b.log_time_ns, b.data) for b in marks] == [
        ("fall", messages[2][3] + 5, {"robot": "robot2"}),
        ("goal", messages[5][3], {"team": "blue", "score": [1, 0]})]
    with open(path, "rb") as f:
        reader = make_reader(f)
        assert [m.name for m in reader.iter_metadata()] == ["bookmark", "bookmark"]


# -- (e) rotation ----------------------------------------------------------------------------------------


def test_rotation_by_size_gives_files_that_each_open(tmp_path: Path) -> None:
    path = tmp_path / "game.mcap"
    messages = mixed_messages(400)
    with LogWriter(path, chunk_size=4000, rotate_bytes=20_000, compression="none") as writer:
        for i, (robot, topic, msg, t) in enumerate(messages):
            writer.write(robot, topic, msg, log_time_ns=t)
            if i % 150 == 0:
                writer.add_bookmark(f"mark {i}", t)
        written = list(writer.paths)
    files = log_series(path)
    assert files == written and len(files) >= 3
    assert files[0] == path and files[1].name == "game_001.mcap" and files[2].name == "game_002.mcap"
    seen: list[int] = []
    previous_end = 0
    for file in files:
        with open(file, "rb") as f:  # the data section stays within rotate_bytes (slack: message indexes)
            f.seek(-(8 + 29), 2)
            summary_start = int.from_bytes(f.read(29)[9:17], "little")
        assert 20_000 - 4000 - 1000 < summary_start < 20_000 + 1000 or file == files[-1]
        with LogReader(file) as reader:
            assert reader.indexed and not reader.warnings
            assert reader.start_ns > previous_end
            previous_end = reader.end_ns
            seen += [m.log_time_ns for m in reader.messages()]
        with open(file, "rb") as f:
            assert sum(1 for _ in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages()) > 0
    assert seen == [t for *_, t in messages]

    progress: list[float] = []
    with LogSeriesReader(path, on_progress=progress.append) as series:
        assert series.message_count == len(messages) and not series.warnings
        assert series.start_ns == messages[0][3] and series.end_ns == messages[-1][3]
        counts = {(c.robot_id, c.topic): c.message_count for c in series.channels}
        expected = sum(1 for robot, topic, *_ in messages if (robot, topic) == ("robot1", "joint_states"))
        assert counts[("robot1", "joint_states")] == expected
        middle = messages[len(messages) // 2][3]
        assert [m.log_time_ns for m in series.messages(start_ns=middle)] == [t for *_, t in messages if t >= middle]
        assert [b.name for b in series.bookmarks] == [f"mark {i}" for i in range(0, len(messages), 150)]
    assert progress[-1] == 1.0


# -- (f) seeking -----------------------------------------------------------------------------------------


def test_seek_starts_at_the_right_message_and_stays_in_order(tmp_path: Path) -> None:
    path = tmp_path / "seek.mcap"
    messages = mixed_messages(500)
    write_log(path, messages, chunk_size=4096)
    times = [t for *_, t in messages]
    with LogReader(path) as reader:
        for k in (0, 1, 137, len(messages) // 2, len(messages) - 1):
            got = list(reader.messages(start_ns=times[k]))
            assert [m.log_time_ns for m in got] == times[k:]
            assert_same(messages[k][2], got[0].msg)
        between = times[300] + 1  # no message at this time: start at the next one
        first = next(iter(reader.messages(start_ns=between)))
        assert first.log_time_ns == times[301]
        window = list(reader.messages(start_ns=times[100], end_ns=times[200]))
        assert [m.log_time_ns for m in window] == times[100:200]
        robot2 = list(reader.messages(start_ns=times[250], topics=["joint_states"], robots=["robot2"]))
        assert robot2 and all(m.robot_id == "robot2" and m.topic == "joint_states" for m in robot2)
        expected = [t for r, topic, _, t in messages[250:] if r == "robot2" and topic == "joint_states"]
        assert [m.log_time_ns for m in robot2] == expected
        assert list(reader.messages(start_ns=times[-1] + 1)) == []


def test_out_of_order_writes_come_back_in_time_order(tmp_path: Path) -> None:
    path = tmp_path / "late.mcap"
    rng = np.random.default_rng(7)
    stamps = [T0 + int(x) for x in rng.integers(0, 10**9, 400)]
    with LogWriter(path, chunk_size=1500) as writer:
        for i, t in enumerate(stamps):
            writer.write(f"robot{i % 2}", "speak_log", schemas.make("std_msgs/msg/String", data=str(i)), log_time_ns=t)
    middle = sorted(stamps)[200]
    with LogReader(path) as reader:
        got = [m.log_time_ns for m in reader.messages(start_ns=middle)]
    assert got == sorted(t for t in stamps if t >= middle)


# -- crash safety while the log is still open -----------------------------------------------------------


def test_open_log_reads_everything_flushed_so_far(tmp_path: Path) -> None:
    path = tmp_path / "live.mcap"
    writer = LogWriter(path, flush_interval_s=None)
    try:
        for i in range(5):
            writer.write("robot1", "joint_states", joint_state(i), log_time_ns=T0 + i)
        with LogReader(path) as reader:  # 1 MiB chunk still open in memory: nothing on disk yet
            assert list(reader.messages()) == []
        writer.flush()
        with LogReader(path) as reader:
            assert [m.msg.header.frame_id for m in reader.messages()] == [f"base_{i}" for i in range(5)]
            assert reader.warnings and not reader.indexed
    finally:
        writer.close()
    with LogReader(path) as reader:
        assert reader.indexed and not reader.warnings and reader.message_count == 5


def test_flush_interval_writes_slow_streams_chunk_by_chunk(tmp_path: Path) -> None:
    path = tmp_path / "slow.mcap"
    with LogWriter(path, flush_interval_s=0.0) as writer:  # every write is past the interval
        for i in range(3):
            writer.write("robot1", "paused", schemas.make("std_msgs/msg/Bool", data=True), log_time_ns=T0 + i)
            with LogReader(path) as reader:
                assert reader.message_count == i + 1
    with open(path, "rb") as f:
        assert len(make_reader(f).get_summary().chunk_indexes) == 3


def test_a_file_and_a_series_offer_the_same_surface(tmp_path: Path) -> None:
    """Replay takes either: both are LogSource (checked by mypy) and answer alike for one file."""
    from schemas.logs import LogSeriesReader, LogSource

    path = tmp_path / "one.mcap"
    write_log(path, mixed_messages(12))
    sources: list[LogSource] = [LogReader(path), LogSeriesReader(path)]
    try:
        single, series = sources
        assert [c.topic for c in single.channels] == [c.topic for c in series.channels]
        assert (single.topics, single.robots, single.message_count, single.start_ns, single.end_ns) == \
            (series.topics, series.robots, series.message_count, series.start_ns, series.end_ns)
        assert len(list(single.messages())) == len(list(series.messages())) == single.message_count
    finally:
        for source in sources:
            source.close()
