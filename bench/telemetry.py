"""Telemetry sender cost: datagrams/s and CPU % of one core per MB/s sent, the node in its own process."""

from __future__ import annotations

import argparse
import io
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np
import psutil
from PIL import Image

import schemas
from robot_nodes.runtime import BusConfig, Node, open_router
from schemas.messages import RobotControlState
from schemas.std import CompressedImage, Imu, JointState
from tests.support import free_port

REPO = Path(__file__).resolve().parents[1]


class Counter:
    """The team PC: a UDP socket that only counts (no decoding, so it costs the sender nothing)."""

    def __init__(self) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 << 20)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        self.datagrams = 0
        self.bytes = 0
        self._stop = False
        threading.Thread(target=self._run, daemon=True).start()

    def _run(self) -> None:
        while not self._stop:
            try:
                data = self.sock.recv(2048)
            except TimeoutError:
                continue
            self.datagrams += 1
            self.bytes += len(data)

    def close(self) -> None:
        self._stop = True


class RobotTopics(Node):
    """The robot's other nodes: camera at 30 Hz (more to saturate), joint states and IMU at 100 Hz, state 50 Hz."""

    name = "bench_publisher"
    camera_hz = 30.0

    def setup(self) -> None:
        cam, js, imu, state = (self.publisher(t) for t in ("camera/image/compressed", "joint_states", "imu/data",
                                                            "robot_state"))
        rng = np.random.default_rng(0)
        pixels = rng.integers(0, 255, (60, 80, 3), dtype=np.uint8).repeat(8, 0).repeat(8, 1)
        buf = io.BytesIO()
        Image.fromarray(pixels).save(buf, format="JPEG", quality=85)
        image = schemas.make(CompressedImage, format="jpeg",
                             data=np.frombuffer(buf.getvalue(), np.uint8))
        joints = schemas.make(JointState, name=[f"j{i}" for i in range(20)],
                              position=np.zeros(20), velocity=np.zeros(20), effort=np.zeros(20))
        self.image_bytes = len(buf.getvalue())
        self.timer(lambda: cam.publish(image), rate_hz=self.camera_hz, name="camera")
        self.timer(lambda: js.publish(joints), rate_hz=100, name="joints")
        self.timer(lambda: imu.publish(schemas.make(Imu)), rate_hz=100, name="imu")
        self.timer(lambda: state.publish(schemas.make(RobotControlState)), rate_hz=50, name="state")


def run_sender(endpoint: str, seconds: float, image_max_width: int) -> tuple[float, float, float]:
    """(datagrams/s, MB/s, CPU % of one core) of a sender process over ``seconds`` of steady traffic."""
    counter = Counter()
    topics = "camera/image/compressed:1000,joint_states:100,imu/data:100,robot_state:50"
    cmd = [sys.executable, "-m", "robot_nodes.telemetry", "--robot-id", "bench1", "--connect", endpoint,
           "--log-level", "ERROR", "--set", f"destination=127.0.0.1:{counter.port}",
           "--set", "budget_bytes_per_s=20000000", "--set", f"topics={topics}",
           "--set", f"image_max_width={image_max_width}", "--set", "allow_dev_key=true"]
    proc = subprocess.Popen(cmd, cwd=REPO, env={**os.environ, "PYTHONWARNINGS": "ignore"})
    try:
        deadline = time.monotonic() + 30
        while counter.datagrams < 200:
            if time.monotonic() > deadline or proc.poll() is not None:
                raise SystemExit("the telemetry sender did not start sending")
            time.sleep(0.1)
        time.sleep(2.0)  # warm up
        ps = psutil.Process(proc.pid)
        cpu0, d0, b0, t0 = sum(ps.cpu_times()[:2]), counter.datagrams, counter.bytes, time.monotonic()
        time.sleep(seconds)
        cpu1, d1, b1, t1 = sum(ps.cpu_times()[:2]), counter.datagrams, counter.bytes, time.monotonic()
    finally:
        proc.terminate()
        proc.wait(10)
        counter.close()
    wall = t1 - t0
    return (d1 - d0) / wall, (b1 - b0) / wall / 1e6, 100 * (cpu1 - cpu0) / wall


def baseline(datagrams_per_s: float, seconds: float = 3.0) -> tuple[float, float]:
    """Plain sendto of 1,400-byte datagrams at the same rate in this process: (MB/s, CPU %)."""
    out = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.bind(("127.0.0.1", 0))
    address, payload = sink.getsockname(), os.urandom(1400)
    me = psutil.Process()
    cpu0, t0, sent = sum(me.cpu_times()[:2]), time.monotonic(), 0
    while (now := time.monotonic()) - t0 < seconds:
        while sent < (now - t0) * datagrams_per_s:
            out.sendto(payload, address)
            sent += 1  # the sink never reads: the kernel drops what overflows, the sender never waits
        time.sleep(0.001)
    wall = time.monotonic() - t0
    return sent * 1400 / wall / 1e6, 100 * (sum(me.cpu_times()[:2]) - cpu0) / wall


def receiver_rate(n: int = 20_000) -> float:
    """Whole joint_states messages/s the receiver authenticates, checks and decodes on one core."""
    from schemas.codec import schema_hash
    from wire.telemetry.datagram import (
        TABLE_HASH,
        TABLE_STREAM,
        DatagramWriter,
        Kind,
        StreamInfo,
        encode_stream_tables,
    )
    from wire.telemetry.receiver import TelemetryReceiver

    key, typename = os.urandom(32), "sensor_msgs/msg/JointState"
    writer, receiver = DatagramWriter(key, "bench1"), TelemetryReceiver(key)
    for body in encode_stream_tables([StreamInfo(1, "joint_states", typename, schema_hash(typename), 1, 100)], 1):
        for d in writer.message(Kind.STREAM_TABLE, TABLE_STREAM, TABLE_HASH, body):
            receiver.feed(d)
    payload = schemas.encode(schemas.make(typename, name=[f"j{i}" for i in range(20)], position=np.zeros(20)))
    datagrams = [writer.message(Kind.MESSAGE, 1, schema_hash(typename), payload)[0] for _ in range(n)]
    start = time.perf_counter()
    got = sum(len(receiver.feed(d)) for d in datagrams)
    elapsed = time.perf_counter() - start
    assert got == n, receiver.counters()
    return n / elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    args = parser.parse_args()
    if args.smoke:
        args.seconds = 1.0
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = open_router([endpoint])
    pub = RobotTopics(robot_id="bench1", bus=BusConfig(connect=[endpoint]))
    pub.start()
    fast = None
    try:
        print(f"offered: camera JPEG {pub.image_bytes} B at 30 Hz, joint_states + imu at 100 Hz, robot_state 50 Hz")
        dps, mbps, cpu = run_sender(endpoint, args.seconds, image_max_width=0)
        per_mb = cpu / mbps if mbps else float("nan")
        print(f"pass-through images: {dps:8.0f} datagrams/s {mbps:6.2f} MB/s  CPU {cpu:5.1f} %  "
              f"-> {per_mb:5.1f} % per MB/s")
        sdps, smbps, scpu = run_sender(endpoint, args.seconds, image_max_width=320)
        print(f"downscaled to 320 px: {sdps:7.0f} datagrams/s {smbps:6.2f} MB/s  CPU {scpu:5.1f} %  "
              f"-> {scpu / smbps if smbps else float('nan'):5.1f} % per MB/s (JPEG decode+encode dominate)")
        pub.shutdown()
        RobotTopics.camera_hz = 150.0
        fast = RobotTopics(robot_id="bench1", bus=BusConfig(connect=[endpoint]))
        fast.start()
        mdps, mmbps, mcpu = run_sender(endpoint, args.seconds, image_max_width=0)
        print(f"camera at 150 Hz:         {mdps:5.0f} datagrams/s {mmbps:6.2f} MB/s  CPU {mcpu:5.1f} %  "
              f"-> {mcpu / mmbps if mmbps else float('nan'):5.1f} % per MB/s")
        bmbps, bcpu = baseline(dps)
        base_per_mb = bcpu / bmbps if bmbps else float("nan")
        print(f"baseline, plain sendto at the same datagram rate: {bmbps:6.2f} MB/s CPU {bcpu:5.1f} % "
              f"-> {base_per_mb:5.1f} % per MB/s; sender/baseline = {per_mb / base_per_mb:4.1f}x")
        rx = receiver_rate()
        print(f"receiver: {rx:.0f} joint_states messages/s authenticated and decoded (one core)")
    finally:
        pub.shutdown()
        if fast is not None:
            fast.shutdown()
        router.close()
    print(f"RESULT telemetry datagrams_per_s={dps:.0f} cpu_pct_per_mbps={per_mb:.2f} mbps={mbps:.3f} "
          f"cpu_pct={cpu:.1f} downscale_cpu_pct={scpu:.1f} downscale_mbps={smbps:.3f} "
          f"high_datagrams_per_s={mdps:.0f} high_mbps={mmbps:.3f} high_cpu_pct={mcpu:.1f} "
          f"baseline_cpu_pct_per_mbps={base_per_mb:.2f} receiver_msgs_per_s={rx:.0f}")


if __name__ == "__main__":
    main()
