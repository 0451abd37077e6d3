"""MCAP log speed: writing 20-joint JointStates, opening the log, seeking to random times.

    python bench/mcap_log.py [--messages 100000] [--robots 4]

Baseline for seeking (same file, same process): plain `mcap` SeekingReader + mcap-ros2-support
decoder, `iter_decoded_messages(starting_at=t)`, first message. A seek is "open iterator at t,
decode the first 100 messages".
"""

from __future__ import annotations

import argparse
import random
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

import schemas
from schemas.logs import LogReader, LogWriter
from schemas.std import JointState

JOINTS = ["HeadPan", "HeadTilt", "LShoulderPitch", "LShoulderRoll", "LElbow", "RShoulderPitch", "RShoulderRoll",
          "RElbow", "LHipYaw", "LHipRoll", "LHipPitch", "LKnee", "LAnklePitch", "LAnkleRoll", "RHipYaw",
          "RHipRoll", "RHipPitch", "RKnee", "RAnklePitch", "RAnkleRoll"]
T0 = 1_700_000_000_000_000_000
PERIOD_NS = 10_000_000  # 100 Hz per robot
READ_AFTER_SEEK = 100


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--messages", type=int, default=100_000)
    parser.add_argument("--robots", type=int, default=4)
    parser.add_argument("--seeks", type=int, default=10)
    parser.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    args = parser.parse_args()
    if args.smoke:
        args.messages, args.robots, args.seeks = 2000, 1, 2
    rng = random.Random(1)

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.mcap"
        msg = schemas.make(JointState, name=JOINTS, position=[0.1] * 20, velocity=[0.2] * 20,
                           effort=[0.3] * 20)
        noise = np.random.default_rng(1).normal(0.0, 1.0, (997, 20))
        start = time.perf_counter()
        with LogWriter(path) as writer:
            for i in range(args.messages):
                robot = i % args.robots
                t = T0 + (i // args.robots) * PERIOD_NS + robot
                msg.position[:] = noise[i % len(noise)]  # realistic entropy: real joint data barely compresses
                writer.write(f"robot{robot}", "joint_states", msg, log_time_ns=t)
        write_s = time.perf_counter() - start
        size_mb = path.stat().st_size / 1e6
        print(f"write: {args.messages} JointState (20 joints) in {write_s:.2f} s = "
              f"{args.messages / write_s:,.0f} msg/s, file {size_mb:.1f} MB")

        start = time.perf_counter()
        reader = LogReader(path)
        open_ms = (time.perf_counter() - start) * 1e3
        print(f"open: {open_ms:.2f} ms ({len(reader.channels)} channels, {reader.duration:.1f} s of log)")

        targets = [rng.randint(reader.start_ns, reader.end_ns) for _ in range(args.seeks)]
        ours, first_ms = [], []
        for t in targets:
            start = time.perf_counter()
            items = reader.messages(start_ns=t)
            first = next(items)
            first_ms.append((time.perf_counter() - start) * 1e3)
            for _ in range(READ_AFTER_SEEK - 1):
                next(items, None)
            ours.append((time.perf_counter() - start) * 1e3)
            assert first.log_time_ns >= t
        reader.close()

        base = []
        with open(path, "rb") as f:
            plain = make_reader(f, decoder_factories=[DecoderFactory()])
            plain.get_summary()
            for t in targets:
                start = time.perf_counter()
                decoded = plain.iter_decoded_messages(starting_at=t)
                for _ in range(READ_AFTER_SEEK):
                    next(decoded, None)
                base.append((time.perf_counter() - start) * 1e3)

    seek_p50, seek_max = statistics.median(ours), max(ours)
    base_p50 = statistics.median(base)
    print(f"seek + {READ_AFTER_SEEK} decoded messages: p50 {seek_p50:.2f} ms, max {seek_max:.2f} ms; "
          f"first message p50 {statistics.median(first_ms):.2f} ms")
    print(f"baseline mcap + mcap-ros2-support: p50 {base_p50:.2f} ms; ratio ours/baseline {seek_p50 / base_p50:.2f}")
    print(f"RESULT mcap_log write_msgs_per_s={args.messages / write_s:.0f} open_ms={open_ms:.2f} "
          f"seek_p50_ms={seek_p50:.2f} seek_max_ms={seek_max:.2f} baseline_seek_p50_ms={base_p50:.2f} "
          f"file_mb={size_mb:.1f}")


if __name__ == "__main__":
    main()
