"""The simulated world's cost per robot, and what it is made of: stepping, perception stand-ins, publishing.

    python bench/world.py [--seconds 15] [--robots 1,2,4,8]

Runs the world process as the demo does (``python -m robot_nodes.sim --robots N``: MuJoCo and one cm730 node
per robot) against a Zenoh router in this process, with a subscriber to every robot's joint_states and imu/data
(as each robot's own nodes would be), and measures the CPU time of the world's process (% of one core) and its
real-time factor (the ``real_time_factor`` diagnostic, minimum over 1 s windows). Each N runs in four
configurations, so their differences give the shares:

- ``stepping``: physics and the servo model only (joint_states at 1 Hz, perception at 0.1 Hz, no camera);
- ``+ publishing``: joint_states and imu/data at 100 Hz, encoded for the subscriber;
- ``+ perception``: the perception stand-ins at 10 Hz for every robot (detections, relative positions, position);
- ``+ one camera``: robot1 renders its head camera (JPEG at 10 Hz), as the demo's default ``--cameras 1``.

The baseline in the same run: the first configuration with one robot.
"""

from __future__ import annotations

import argparse
import contextlib
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import psutil

import schemas
from robot_nodes.runtime import BusConfig, open_router, open_session
from schemas.std import DiagnosticArray
from tests.support import REPO, free_port
from wire import keys

CONFIGURATIONS = {
    "stepping": ["--cameras", "0", "--set", "publish_rate=1", "--set", "camera_rate=0.1"],
    "+ publishing": ["--cameras", "0", "--set", "camera_rate=0.1"],
    "+ perception": ["--cameras", "0"],
    "+ one camera": ["--cameras", "1"],
}
SETTLE_S = 8.0


def run(robots: int, extra: list[str], seconds: float, endpoint: str) -> tuple[float, float, float]:
    """(CPU % of one core, minimum real-time factor, messages/s received)."""
    received = [0]
    factors: list[float] = []

    def on_diagnostics(sample: object) -> None:
        msg = schemas.decode(sample.payload.to_bytes(), DiagnosticArray)  # type: ignore[attr-defined]
        for status in msg.status:
            for kv in status.values:
                if kv.key == "real_time_factor" and status.name == "robot1/cm730":
                    factors.append(float(kv.value))

    world = subprocess.Popen([sys.executable, "-m", "robot_nodes.sim", "--robots", str(robots), "--connect",
                              endpoint, *extra], cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    with open_session(BusConfig(connect=[endpoint])) as session:
        subs = [session.declare_subscriber(keys.topic_key("*", topic), lambda _s: received.__setitem__(
            0, received[0] + 1)) for topic in ("joint_states", "imu/data")]
        subs.append(session.declare_subscriber(keys.topic_key("robot1", "diagnostics"), on_diagnostics))
        # someone watches robot1's camera: it renders when its node may (--cameras 1)
        subs.append(session.declare_subscriber(keys.topic_key("robot1", "camera/image/compressed"), lambda _s: None))
        try:
            time.sleep(SETTLE_S)
            process = psutil.Process(world.pid)
            c0, t0, n0, f0 = sum(process.cpu_times()[:2]), time.monotonic(), received[0], len(factors)
            time.sleep(seconds)
            cpu = 100.0 * (sum(process.cpu_times()[:2]) - c0) / (time.monotonic() - t0)
            rate = (received[0] - n0) / (time.monotonic() - t0)
        finally:
            for sub in subs:
                with contextlib.suppress(Exception):
                    sub.undeclare()
            world.terminate()
            world.wait(20)
    window = factors[f0 + 1:] or factors[-1:] or [0.0]
    return cpu, min(window), rate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=15.0)
    parser.add_argument("--robots", default="1,2,4,8")
    parser.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    args = parser.parse_args()
    if args.smoke:
        args.seconds, args.robots = 2.0, "1"
    sizes = sorted({int(n) for n in args.robots.split(",")})
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = open_router([endpoint])
    table: dict[tuple[int, str], tuple[float, float, float]] = {}
    try:
        for n in sizes:
            for name, extra in CONFIGURATIONS.items():
                table[(n, name)] = run(n, extra, args.seconds, endpoint)
                cpu, rtf, rate = table[(n, name)]
                print(f"{n} robot{'s' if n > 1 else ' '} {name:14s} CPU {cpu:5.1f} %  rtf min {rtf:.3f}  "
                      f"{rate:6.0f} state msgs/s")
    finally:
        router.close()
    first, last = sizes[0], sizes[-1]
    extra_robots = max(last - first, 1)
    shares = {}
    previous = 0.0
    for name in CONFIGURATIONS:
        marginal = (table[(last, name)][0] - table[(first, name)][0]) / extra_robots
        shares[name] = marginal - previous
        previous = marginal
    baseline = table[(first, "stepping")][0]
    total = table[(last, "+ one camera")][0]
    print(f"\nper further robot: stepping {shares['stepping']:.1f} %, publishing {shares['+ publishing']:.1f} %, "
          f"perception {shares['+ perception']:.1f} %; the camera of one robot "
          f"{table[(last, '+ one camera')][0] - table[(last, '+ perception')][0]:.1f} %; "
          f"{last} robots cost {total / baseline:.1f}x the baseline of {first} robot stepping ({baseline:.1f} %)")
    print(f"RESULT world cpu_pct_per_robot={previous:.1f} stepping_pct_per_robot={shares['stepping']:.1f} "
          f"publishing_pct_per_robot={shares['+ publishing']:.1f} "
          f"perception_pct_per_robot={shares['+ perception']:.1f} cpu_pct_{last}={total:.1f} "
          f"rtf_min_{last}={table[(last, '+ one camera')][1]:.3f}")


if __name__ == "__main__":
    main()
