"""The dashboard hub: fan-out, late joiners, rate limits and bounded queues for slow subscribers."""

from __future__ import annotations

import asyncio
import time
import tracemalloc

import schemas
from server.hub import Hub, HubMessage
from server.protocol import frame_of


def state_msg(robot: str = "r1", topic: str = "robot_state", state: int = 0) -> HubMessage:
    msg = schemas.make("humanoid_league_msgs/msg/RobotControlState", state=state)
    return HubMessage(robot, topic, msg.__msgtype__, time.time(), msg, "test")


def test_fan_out_and_filters() -> None:
    async def main() -> None:
        hub = Hub()
        everything = hub.subscribe()
        everything.subscribe("*", "*")
        only_r2 = hub.subscribe()
        only_r2.subscribe("r2", "robot_state")
        cams = hub.subscribe()
        cams.subscribe("*", "camera/*")
        hub.publish(state_msg("r1"))
        hub.publish(state_msg("r2", state=3))
        hub.publish(state_msg("r2", topic="camera/image/compressed"))
        assert [(m.robot, m.topic) for m in everything.drain()] == [
            ("r1", "robot_state"), ("r2", "robot_state"), ("r2", "camera/image/compressed")]
        got = only_r2.drain()
        assert [(m.robot, m.message.state) for m in got] == [("r2", 3)]
        assert [m.topic for m in cams.drain()] == ["camera/image/compressed"]
        assert sorted(hub.robots) == ["r1", "r2"]

    asyncio.run(main())


def test_late_joiner_gets_latest_per_stream() -> None:
    async def main() -> None:
        hub = Hub()
        for state in range(5):
            hub.publish(state_msg("r1", state=state))
        hub.publish(state_msg("r2", state=9))
        late = hub.subscribe()
        late.subscribe("*", "robot_state")
        assert sorted((m.robot, m.message.state) for m in late.drain()) == [("r1", 4), ("r2", 9)]

    asyncio.run(main())


def test_rate_limit_keeps_the_newest() -> None:
    async def main() -> None:
        hub = Hub()
        sub = hub.subscribe()
        sub.subscribe("*", "robot_state", max_hz=5)
        received: list[int] = []
        start = time.monotonic()
        state = 0
        while time.monotonic() - start < 1.0:  # publish at ~200 Hz for one second
            hub.publish(state_msg(state=state % 256))
            state += 1
            await asyncio.sleep(0.005)
            received += [m.message.state for m in sub.drain()]
        last_published = (state - 1) % 256
        await asyncio.sleep(0.3)  # the held newest message is released after the period
        received += [m.message.state for m in sub.drain()]
        assert 2 <= len(received) <= 8, received  # at most 5 Hz (+ first and the last held one)
        assert received[-1] == last_published  # the newest always arrives
        assert sub.thinned > 0

    asyncio.run(main())


def test_never_reading_subscriber_is_bounded_and_does_not_slow_others() -> None:
    async def main() -> None:
        hub = Hub()
        stuck = hub.subscribe(maxlen=100)
        stuck.subscribe()
        reader = hub.subscribe(maxlen=100)
        reader.subscribe()
        got = 0
        tracemalloc.start()
        for i in range(20_000):
            hub.publish(state_msg(state=i % 256))
            got += len(reader.drain())
        current, _ = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        assert got == 20_000  # the reader saw every message
        assert len(stuck) == 100 and stuck.dropped == 19_900  # the stuck one lost its oldest
        assert [m.message.state for m in stuck.drain()][-1] == 19_999 % 256
        assert current < 5_000_000, f"hub kept {current} bytes"

    asyncio.run(main())


def test_frame_is_built_once_and_bad_cdr_is_an_error_not_a_crash() -> None:
    async def main() -> None:
        hub = Hub()
        msg = state_msg(state=2)
        first = frame_of(msg)
        assert first is frame_of(msg)
        assert '"state":2' in str(first)
        bad = HubMessage("r1", "joint_states", "sensor_msgs/msg/JointState", 0.0, b"\x00\x01garbage", "test")
        hub.publish(bad)
        try:
            frame_of(bad)
        except schemas.SchemaError as exc:
            assert "JointState" in str(exc)
        else:
            raise AssertionError("garbage CDR decoded")

    asyncio.run(main())


def test_threadsafe_publish_from_another_thread() -> None:
    async def main() -> None:
        hub = Hub()
        hub.bind(asyncio.get_running_loop())
        sub = hub.subscribe()
        sub.subscribe()
        await asyncio.to_thread(hub.publish_threadsafe, [state_msg(state=i) for i in range(10)])
        assert await sub.wait(timeout=5.0)
        await asyncio.sleep(0)
        assert [m.message.state for m in sub.drain()] == list(range(10))

    asyncio.run(main())


def test_robots_and_streams_beyond_the_bounds_are_refused_and_counted() -> None:
    """A process on the bus inventing robot ids or topics cannot grow the hub (its memory is bounded by design)."""
    from server.hub import MAX_ROBOTS, MAX_STREAMS

    hub = Hub()
    sub = hub.subscribe("all")
    sub.subscribe("*", "*")
    for i in range(MAX_ROBOTS + 10):
        hub.publish(state_msg(robot=f"r{i}"))
    assert len(hub.robots) == MAX_ROBOTS and hub.refused == 10
    for i in range(MAX_STREAMS):
        hub.publish(state_msg(robot="r0", topic=f"t{i}"))
    assert hub.streams == MAX_STREAMS and len(hub.latest) == MAX_STREAMS
    assert hub.refused == 10 + MAX_ROBOTS  # the other robots' first streams filled the table before r0's last ones
    hub.forget("r1")
    hub.publish(state_msg(robot="r0", topic="one more"))
    assert ("r0", "one more") in hub.latest, "a forgotten robot's streams make room again"
