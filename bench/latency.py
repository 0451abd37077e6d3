"""One-way latency of a 20-joint JointTrajectory between two processes, through the runtime and raw Zenoh, and
between two nodes composed in one process.

    python bench/latency.py [--seconds 5]

The receiver (this process) and the publisher (a child process) share the machine clock; the publisher puts
its send time into header.stamp. Raw Zenoh sends the very same CDR bytes without the runtime around them. The
composed hop is the in-process delivery of robot_nodes/runtime/local_bus.py: the message object handed to the
receiving node's loop, no CDR, no Zenoh.
"""

from __future__ import annotations

import argparse
import statistics
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import zenoh

import schemas
from robot_nodes.runtime import BusConfig, Node, open_router, open_session
from schemas.std import JointTrajectory, JointTrajectoryPoint
from wire import keys

JOINTS = ["HeadPan", "HeadTilt", "LShoulderPitch", "LShoulderRoll", "LElbow", "RShoulderPitch", "RShoulderRoll",
          "RElbow", "LHipYaw", "LHipRoll", "LHipPitch", "LKnee", "LAnklePitch", "LAnkleRoll", "RHipYaw",
          "RHipRoll", "RHipPitch", "RKnee", "RAnklePitch", "RAnkleRoll"]
TOPIC = "motor_goals"
STAMP = struct.Struct("<iI")  # CDR: 4-byte encapsulation header, then header.stamp (sec, nanosec)


def trajectory() -> JointTrajectory:
    point = schemas.make(JointTrajectoryPoint, positions=[0.1] * 20, velocities=[0.5] * 20,
                         effort=[1.0] * 20)
    return schemas.make(JointTrajectory, joint_names=JOINTS, points=[point])


def stamp_now(msg: object) -> None:
    t = time.time_ns()
    msg.header.stamp.sec, msg.header.stamp.nanosec = t // 1_000_000_000, t % 1_000_000_000  # type: ignore[attr-defined]


def fresh(template: JointTrajectory) -> JointTrajectory:
    """A new message sharing the template's point: a published one is frozen, never stamped again. It is made
    before the send time is taken, so the figures time the hop, not building a message."""
    return schemas.make(JointTrajectory, joint_names=template.joint_names, points=template.points)


class Sender(Node):
    """Publishes a fresh-stamped trajectory at the benchmark rate (the runtime path: encode + put)."""

    name = "latency_sender"

    def __init__(self, hz: float, count: int, **kwargs: object) -> None:
        self.hz, self.count, self.sent = hz, count, 0
        super().__init__(**kwargs)  # type: ignore[arg-type]

    def setup(self) -> None:
        self.msg = trajectory()
        self.pub = self.publisher(TOPIC)
        self.timer(self.tick, rate_hz=self.hz)

    def tick(self) -> None:
        if self.sent >= self.count:
            self.loop.call_soon(self.shutdown)
            return
        msg = fresh(self.msg)
        stamp_now(msg)
        self.pub.publish(msg)
        self.sent += 1


def publisher_main(mode: str, hz: float, count: int, endpoint: str) -> None:
    bus = BusConfig(connect=[endpoint])
    time.sleep(1.0)  # let the receiver's subscription reach us
    if mode == "runtime":
        Sender(hz, count, robot_id="bench", bus=bus).spin()
        return
    session = open_session(bus)
    pub = session.declare_publisher(keys.topic_key("bench", TOPIC))
    msg = trajectory()
    period = 1.0 / hz
    next_due = time.monotonic()
    for _ in range(count):
        next_due += period
        delay = next_due - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        stamp_now(msg)
        pub.put(schemas.encode(msg))
    session.close()


class Receiver(Node):
    name = "latency_receiver"

    def setup(self) -> None:
        self.latencies: list[float] = []
        self.subscribe(TOPIC, self.on_goals)

    def on_goals(self, msg: object) -> None:
        stamp = msg.header.stamp  # type: ignore[attr-defined]
        self.latencies.append((time.time_ns() - (stamp.sec * 1_000_000_000 + stamp.nanosec)) / 1e6)


def measure_composed(hz: float, seconds: float, endpoint: str) -> list[float]:
    """Sender and receiver as two nodes of this process (one session): the in-process hop."""
    count = int(hz * seconds)
    with open_session(BusConfig(connect=[endpoint])) as session:
        receiver = Receiver(robot_id="bench", bus=session).start()
        sender = Sender(hz, count, robot_id="bench", bus=session)
        sender.spin()  # until it has sent count messages
        time.sleep(0.3)
        receiver.shutdown()
    return receiver.latencies[count // 10:] or receiver.latencies


def measure(mode: str, hz: float, seconds: float, endpoint: str) -> list[float]:
    if mode == "composed":
        return measure_composed(hz, seconds, endpoint)
    count = int(hz * seconds)
    bus = BusConfig(connect=[endpoint])
    if mode == "runtime":
        receiver = Receiver(robot_id="bench", bus=bus).start()
        latencies = receiver.latencies
    else:
        latencies = []
        session = open_session(bus)
        lock = threading.Lock()

        def on_sample(sample: zenoh.Sample) -> None:
            sec, nanosec = STAMP.unpack_from(sample.payload.to_bytes(), 4)
            with lock:
                latencies.append((time.time_ns() - (sec * 1_000_000_000 + nanosec)) / 1e6)

        sub = session.declare_subscriber(keys.topic_key("bench", TOPIC), on_sample)
    child = subprocess.Popen([sys.executable, __file__, "--publisher", mode, "--hz", str(hz), "--count", str(count),
                              "--connect", endpoint])
    child.wait(seconds * 3 + 30)
    time.sleep(0.3)
    if mode == "runtime":
        receiver.shutdown()
    else:
        sub.undeclare()
        session.close()
    return latencies[count // 10:] or latencies  # skip the warm-up tenth


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--publisher", choices=["runtime", "raw"])
    parser.add_argument("--hz", type=float, default=100.0)
    parser.add_argument("--count", type=int, default=0)
    parser.add_argument("--connect", default="")
    parser.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    args = parser.parse_args()
    if args.smoke:
        args.seconds = 1.0
    if args.publisher:
        publisher_main(args.publisher, args.hz, args.count, args.connect)
        return
    from tests.support import free_port

    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = open_router([endpoint])
    payload = len(schemas.encode(trajectory()))
    print(f"payload: JointTrajectory with 20 joints, {payload} bytes CDR; {args.seconds:.0f} s per run")
    results: dict[tuple[str, float], list[float]] = {}
    for mode in ("raw", "runtime", "composed"):
        for hz in (100.0, 1000.0):
            lat = measure(mode, hz, args.seconds, endpoint)
            results[(mode, hz)] = lat
            print(f"{mode:8s} {hz:6.0f} Hz  n={len(lat):5d}  p50={statistics.median(lat):.3f} ms  "
                  f"p99={percentile(lat, 0.99):.3f} ms  max={max(lat):.3f} ms")
    router.close()
    run_1k, raw_1k = results[("runtime", 1000.0)], results[("raw", 1000.0)]
    composed_1k = results[("composed", 1000.0)]
    p50, raw_p50 = statistics.median(run_1k), statistics.median(raw_1k)
    print(f"RESULT latency p50_ms={p50:.3f} p99_ms={percentile(run_1k, 0.99):.3f} raw_p50_ms={raw_p50:.3f} "
          f"ratio_p50={p50 / raw_p50:.2f} composed_p50_ms={statistics.median(composed_1k):.3f} "
          f"composed_p99_ms={percentile(composed_1k, 0.99):.3f}")


if __name__ == "__main__":
    main()
