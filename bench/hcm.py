"""Cost of the motion chain cm730 (MuJoCo) + HCM + animation as three processes, and its latency.

    python bench/hcm.py [--seconds 6]

The three nodes run as their own processes (`python -m robot_nodes.cm730|hcm|animation`) on a Zenoh router in
this process, at 100 Hz and then at 500 Hz (cm730 publish_rate, hcm rate_hz and animation rate_hz). Once the HCM
stands the robot up (CONTROLLABLE), an external animation (a slow head sway, written to a temporary folder) plays
in a loop through PlayAnimation, so every cycle goes animation -> HCM -> motor_goals -> cm730.

CPU: psutil cpu_percent of each process over the window (100 % = one core), summed.
Latency: the animation node stamps each step's JointTrajectory header; the HCM forwards that trajectory as
motor_goals untouched, so (arrival of motor_goals at a subscriber in this process) - (stamp) is the time from the
animation's sample to the goal reaching the servo bus's side, through two hops and the HCM's decision.
The baseline is one raw hop: the same trajectory put on a key by this process and received by itself.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np
import psutil

import schemas
from robot_nodes.runtime import BusConfig, GoalStatus, Node, header, open_router
from schemas.messages import PlayAnimationGoal
from schemas.std import JointTrajectory, JointTrajectoryPoint
from tests.support import free_port

REPO = Path(__file__).resolve().parents[1]
SWAY = {"name": "bench_sway", "author": "bench/hcm.py", "keyframes": [
    {"duration": 2.0, "goals": {"HeadPan": 40.0}, "name": "left"},
    {"duration": 4.0, "goals": {"HeadPan": -40.0}, "name": "right"},
    {"duration": 2.0, "goals": {"HeadPan": 0.0}, "name": "centre"},
]}


class Bench(Node):
    """Watches robot_state and motor_goals and keeps the sway animation playing."""

    name = "hcm_bench"

    def setup(self) -> None:
        self.state: int | None = None
        self.latencies: list[float] = []
        self.first_hop: list[float] = []  # animation -> here, the same stamp: what the HCM adds is the difference
        self.goals = 0
        self.measuring = False
        self.playing: Any = None
        self.subscribe("robot_state", self.on_state)
        self.subscribe("motor_goals", self.on_goals)
        self.subscribe("animation", self.on_animation)
        self.client = self.action_client("animation")
        self.timer(self.keep_playing, rate_hz=5.0)

    def on_state(self, msg: Any) -> None:
        self.state = int(msg.state)

    def on_goals(self, msg: Any) -> None:
        now = time.time_ns()
        if not self.measuring or list(msg.joint_names) != ["HeadPan"]:
            return
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        self.latencies.append((now - stamp) / 1e6)
        self.goals += 1

    def on_animation(self, msg: Any) -> None:
        now = time.time_ns()
        if self.measuring and list(msg.position.joint_names) == ["HeadPan"]:
            stamp = msg.position.header.stamp
            self.first_hop.append((now - (stamp.sec * 1_000_000_000 + stamp.nanosec)) / 1e6)

    def keep_playing(self) -> None:
        if self.state not in (0, 4) or (self.playing is not None and not self.playing.done):
            return
        if self.playing is not None and self.playing.status not in (None, GoalStatus.SUCCEEDED):
            self.log.warning("sway ended with %s", self.playing.status)
        goal = schemas.make(PlayAnimationGoal, animation="bench_sway", hcm=False)
        self.playing = self.client.send_goal(goal)


def start(module: str, endpoint: str, settings: list[str]) -> subprocess.Popen[bytes]:
    cmd = [sys.executable, "-m", module, "--connect", endpoint, "--log-level", "WARNING"]
    for s in settings:
        cmd += ["--set", s]
    return subprocess.Popen(cmd, cwd=REPO)


def chain(endpoint: str, hz: float, seconds: float, folder: Path) -> tuple[dict[str, float], list[float], float,
                                                                         list[float]]:
    """({process: CPU %}, latencies in ms, motor_goals per second, first-hop latencies in ms) with the chain at hz."""
    bench = Bench("robot1", BusConfig(connect=[endpoint]))
    bench.start()
    procs = {
        "cm730": start("robot_nodes.cm730", endpoint, [f"publish_rate={hz}", "render_camera=false",
                                                       "camera_rate=0.1", "ground_truth_rate=1.0"]),
        "hcm": start("robot_nodes.hcm", endpoint, [f"rate_hz={hz}"]),
        "animation": start("robot_nodes.animation", endpoint, [f"rate_hz={hz}", f"search_path={folder}"]),
    }
    try:
        deadline = time.monotonic() + 60.0
        while bench.state != 4:  # ANIMATION_RUNNING: the robot stands and the sway plays
            if time.monotonic() > deadline or any(p.poll() is not None for p in procs.values()):
                raise SystemExit(f"the chain did not come up (robot_state {bench.state})")
            time.sleep(0.05)
        time.sleep(1.0)
        ps = {name: psutil.Process(p.pid) for name, p in procs.items()}
        for p in ps.values():
            p.cpu_percent(None)
        bench.latencies.clear()
        bench.first_hop.clear()
        bench.goals = 0
        bench.measuring = True
        t0 = time.monotonic()
        time.sleep(seconds)
        bench.measuring = False
        cpu = {name: p.cpu_percent(None) for name, p in ps.items()}
        rate = bench.goals / (time.monotonic() - t0)
        return cpu, list(bench.latencies), rate, list(bench.first_hop)
    finally:
        for name in ("hcm", "animation", "cm730"):  # the HCM first: its sit-down needs the animation node
            procs[name].terminate()
            if name == "hcm":
                try:
                    procs[name].wait(6)
                except subprocess.TimeoutExpired:
                    procs[name].kill()
        for p in procs.values():
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                p.kill()
        bench.shutdown()


def raw_hop(endpoint: str, n: int = 2000) -> list[float]:
    """Baseline: one Zenoh hop of the same trajectory through the router, put and received in this process."""
    from robot_nodes.runtime import open_session

    session = open_session(BusConfig(connect=[endpoint]))
    got: list[float] = []
    done = threading.Event()

    def on_sample(sample: Any) -> None:
        msg = schemas.decode(sample.payload.to_bytes(), JointTrajectory)
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        got.append((time.time_ns() - stamp) / 1e6)
        if len(got) >= n:
            done.set()

    sub = session.declare_subscriber("bench/hcm/raw", on_sample)
    pub = session.declare_publisher("bench/hcm/raw")
    time.sleep(0.5)
    for _ in range(n):
        point = schemas.make(JointTrajectoryPoint, positions=np.zeros(1))
        pub.put(schemas.encode(schemas.make(JointTrajectory, header=header(),
                                            joint_names=["HeadPan"], points=[point])))
        time.sleep(0.002)
    done.wait(5.0)
    sub.undeclare()
    pub.undeclare()
    session.close()
    return got


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=6.0, help="measuring window per rate")
    parser.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    args = parser.parse_args()
    if args.smoke:
        args.seconds = 1.0
    print(f"load average {' '.join(f'{v:.1f}' for v in psutil.getloadavg())} on {psutil.cpu_count()} cores")
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = open_router([endpoint])
    results: dict[float, tuple[dict[str, float], list[float], float, list[float]]] = {}
    try:
        with tempfile.TemporaryDirectory() as tmp:
            (Path(tmp) / "bench_sway.json").write_text(json.dumps(SWAY))
            for hz in (100.0, 500.0):
                cpu, lat, rate, hop = chain(endpoint, hz, args.seconds, Path(tmp))
                results[hz] = (cpu, lat, rate, hop)
                parts = "  ".join(f"{name} {value:5.1f} %" for name, value in cpu.items())
                print(f"{hz:5.0f} Hz: {sum(cpu.values()):5.1f} % of one core ({parts}); "
                      f"{rate:6.1f} animation goals/s reached motor_goals")
                if lat:
                    print(f"         latency animation -> HCM -> motor_goals  p50 {statistics.median(lat):6.3f} ms"
                          f"  p99 {float(np.percentile(lat, 99)):6.3f} ms  ({len(lat)} goals)")
                if hop:
                    print(f"         of which animation -> this process (1 hop)  p50 {statistics.median(hop):6.3f} ms"
                          f"  p99 {float(np.percentile(hop, 99)):6.3f} ms")
        base = raw_hop(endpoint)
    finally:
        router.close()
    cpu100 = sum(results[100.0][0].values())
    cpu500 = sum(results[500.0][0].values())
    lat = results[100.0][1]
    if not lat:
        raise SystemExit("no motor_goals from the animation reached the subscriber")
    p50, p99 = statistics.median(lat), float(np.percentile(lat, 99))
    base50 = statistics.median(base)
    print(f"baseline: one raw Zenoh hop through the router  p50 {base50:6.3f} ms  p99 "
          f"{float(np.percentile(base, 99)):6.3f} ms; chain/baseline {p50 / base50:.1f}")
    print(f"RESULT hcm cpu_pct_100hz={cpu100:.1f} cpu_pct_500hz={cpu500:.1f} latency_p50_ms={p50:.3f} "
          f"latency_p99_ms={p99:.3f} latency_500hz_p50_ms={statistics.median(results[500.0][1]):.3f} "
          f"baseline_hop_p50_ms={base50:.3f} ratio={p50 / base50:.2f}")


if __name__ == "__main__":
    main()
