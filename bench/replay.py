"""Replay of a 1 GB pitchside log: time to open it, to seek (as the timeline does), and playing at 10x.

    python bench/replay.py [--gigabytes 1.0] [--robots 4] [--seeks 10]

The log is generated in a temporary folder (JointState and Imu at 100 Hz, 30 KB CompressedImage at 30 Hz,
per robot) and deleted at the end. A seek is ``ReplaySource.seek``: jump, then publish the newest message of
every stream from the 2 s before the point into the hub (what the panels show); budget < 200 ms (median).
Baseline in the same process: the bare reader's seek (first message at a random time).
"""

from __future__ import annotations

import argparse
import asyncio
import os
import random
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np

import schemas
from schemas.logs import LogWriter
from schemas.std import CompressedImage, Imu, JointState
from server.hub import Hub
from server.sources.replay import ReplaySource

T0 = 1_700_000_000_000_000_000
TICK_NS = 10_000_000  # 100 Hz
IMAGE_EVERY = 3  # ticks: ~33 Hz
IMAGE_BYTES = 30_000


def generate(path: Path, target_bytes: int, robots: int) -> tuple[int, float]:
    """Writes the log; (messages, seconds of log)."""
    rng = np.random.default_rng(1)
    joints = [f"joint{i}" for i in range(20)]
    joint_cdr = schemas.encode(schemas.make(JointState, name=joints,
                                            position=rng.normal(size=20).tolist()))
    imu_cdr = schemas.encode(schemas.make(Imu))
    image = schemas.encode(schemas.make(CompressedImage, format="jpeg",
                                        data=np.zeros(IMAGE_BYTES, dtype=np.uint8)))
    image_head = image[:-IMAGE_BYTES]  # the pixels are the message's last field: fresh noise for every image
    names = [f"robot{r + 1}" for r in range(robots)]
    messages = tick = 0
    with LogWriter(path, compression="zstd") as writer:
        while True:
            t = T0 + tick * TICK_NS
            for robot in names:
                writer.write(robot, "joint_states", joint_cdr, log_time_ns=t)
                writer.write(robot, "imu/data", imu_cdr, log_time_ns=t + 1000)
                messages += 2
                if tick % IMAGE_EVERY == 0:
                    writer.write(robot, "camera/image/compressed", image_head + os.urandom(IMAGE_BYTES),
                                 log_time_ns=t + 2000)
                    messages += 1
            tick += 1
            if tick % 1000 == 0 and path.stat().st_size >= target_bytes:
                break
    return messages, tick * TICK_NS / 1e9


async def measure(path: Path, seeks: int) -> dict[str, float]:
    hub = Hub()
    hub.bind(asyncio.get_running_loop())
    browser = hub.subscribe("browser", maxlen=2000)
    browser.subscribe("*", "*")
    source = ReplaySource(hub)
    started = time.perf_counter()
    info = await source.open(path)
    open_s = time.perf_counter() - started
    duration = info["duration_s"]
    print(f"opened in {open_s * 1000:.1f} ms: {info['messages']} messages, {duration:.1f} s, "
          f"{len(info['topics'])} channels")

    rng = random.Random(7)
    times = []
    for _ in range(seeks):
        t = rng.uniform(0, duration)
        started = time.perf_counter()
        await source.seek(t)
        times.append((time.perf_counter() - started) * 1000)
        browser.drain(10_000)
    print("seek ms:", " ".join(f"{x:.1f}" for x in times))

    reader = source.file.reader if source.file else None
    base = []
    for _ in range(seeks):
        t = T0 + int(rng.uniform(0, duration) * 1e9)
        started = time.perf_counter()
        next(iter(reader.messages(start_ns=t))) if reader else None
        base.append((time.perf_counter() - started) * 1000)
    print(f"baseline (bare reader, first message after a random time) p50 {statistics.median(base):.1f} ms")

    # 10x: a browser-like subscriber drains the hub while the player paces the log
    await source.seek(duration * 0.1)
    source.set_speed(10.0)
    wall_s = 6.0
    start_pos = source.position_ns
    started = time.perf_counter()
    source.play()
    delivered0 = source.delivered
    while time.perf_counter() - started < wall_s and source.state == "playing":
        await browser.wait(0.05)
        browser.drain(10_000)
    elapsed = time.perf_counter() - started
    source.pause()
    achieved = (source.position_ns - start_pos) / 1e9 / elapsed
    rate = (source.delivered - delivered0) / elapsed
    print(f"10x: {achieved:.2f}x achieved, {rate:.0f} messages/s into the hub, browser dropped {browser.dropped}")
    await source.close()
    return {"open_s": open_s, "seek_p50_ms": statistics.median(times), "seek_max_ms": max(times),
            "baseline_seek_p50_ms": statistics.median(base), "replay_speed_achieved": achieved}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gigabytes", type=float, default=1.0)
    parser.add_argument("--robots", type=int, default=4)
    parser.add_argument("--seeks", type=int, default=10)
    parser.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    args = parser.parse_args()
    if args.smoke:
        args.gigabytes, args.robots, args.seeks = 0.005, 1, 2
    folder = Path(tempfile.mkdtemp(prefix="pitchside-bench-replay-"))
    try:
        path = folder / "big.mcap"
        started = time.perf_counter()
        messages, seconds = generate(path, int(args.gigabytes * 1e9), args.robots)
        size = sum(f.stat().st_size for f in folder.iterdir())
        print(f"wrote {size / 1e9:.2f} GB, {messages} messages, {seconds:.0f} s of log from {args.robots} robots "
              f"in {time.perf_counter() - started:.1f} s")
        figures = asyncio.run(measure(path, args.seeks))
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    assert not os.path.exists(folder)
    print(f"RESULT replay open_s={figures['open_s']:.3f} seek_p50_ms={figures['seek_p50_ms']:.1f} "
          f"seek_max_ms={figures['seek_max_ms']:.1f} replay_speed_achieved={figures['replay_speed_achieved']:.2f} "
          f"baseline_seek_p50_ms={figures['baseline_seek_p50_ms']:.1f}")


if __name__ == "__main__":
    main()
