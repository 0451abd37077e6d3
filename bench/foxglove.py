"""The Foxglove endpoint under 11 robots (issue 17 point 9): delivery rate, hub -> client latency, server CPU.

    python bench/foxglove.py [--seconds 8]

The server runs as its own process (``python -m server``, live Zenoh source on a router in this process, no
telemetry); a feeder process publishes 11 robots with the demo's topic mix at the demo's rates (measured on
``pitchside demo``: joint_states and imu 200 Hz, perception and state topics 10 Hz, a 7 KB JPEG at 10 Hz, ...:
~580 msg/s per robot); the real Foxglove client (@foxglove/ws-protocol on Node.js, tests/foxglove_client) runs as
1 and as 5 connections subscribed to every channel. Figures:
- fed_msgs_per_s: what the hub took in; msgs_per_s_1 / msgs_per_s_5: delivered to 1 client / to 5 in total (the
  hub's streams and the channels derived from them: the camera annotations, and the 3D scene's /tf (computed from
  each robot's joint_states and the minibot URDF, 30 Hz per robot), /tf_static, markers and robot descriptions);
  min_client_share: the slowest client's share of the hub's streams, and whether every client kept up (>= 95 %);
- latency_p50_ms / p99: joint_states stamped by the feeder when it sends -> Foxglove client (so hub -> client plus
  one Zenoh hop on loopback), with 1 client; the dashboard's own /ws client on the same stream is the baseline;
- cpu_overhead_pct: server CPU (% of one core) with the endpoint and 1 client subscribed to everything, minus
  the same server with --no-foxglove; the 5-client figure too;
- *_v1: the same 1 client offering only the older subprotocol foxglove.websocket.v1 (Lichtblick before 2026), whose
  bytes the guard copies frame by frame (server.foxglove.subprotocols) instead of in chunks.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import statistics
import struct
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

# the checkout first. This script's folder stays on the path, so `import foxglove` here would find this file, not
# the SDK: no code in this process imports the SDK (server.foxglove imports it only when the endpoint starts)
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import httpx
import numpy as np
import psutil

import robots
import schemas
from robot_nodes.runtime import BusConfig, open_router, open_session
from server.transforms import load_kinematics
from tests.foxglove_node import foxglove_url, run_client
from tests.support import free_port
from tests.waiting import wait_for
from wire.keys import topic_key

REPO = Path(__file__).resolve().parents[1]
ROBOTS = [f"r{i}" for i in range(1, 12)]
# what one demo robot publishes (Hz), measured with the Foxglove client on `pitchside demo`
DEMO_RATES = {
    "joint_states": 200, "imu/data": 200, "ground_truth": 20, "walking_active": 10, "position": 10,
    "robot_state": 10, "overview": 10, "ball_relative": 10, "camera/camera_info": 10, "obstacles_relative": 10,
    "goal_relative": 10, "camera/image/compressed": 10, "obstacles_in_image": 10, "ball_in_image": 10,
    "goal_in_image": 10, "line_information_in_image": 10, "walk_odometry": 10, "diagnostics": 8, "servo_data": 5,
    "paused": 2, "gamestate": 1, "hcm_graph": 1, "servo_health": 1,
}
JOINTS = load_kinematics(robots.urdf()).joint_names  # the minibot's 20: the server computes /tf from them
TICK_HZ = 200  # the feeder's loop: every topic is due every TICK_HZ / rate ticks


# -- the feeder process -----------------------------------------------------------------------------------------
def _payloads() -> dict[str, bytes]:
    out = {}
    for topic in DEMO_RATES:
        typename = schemas.TOPICS[topic].type
        if topic == "joint_states":
            msg = schemas.make(typename, header=schemas.header(), name=JOINTS, position=[0.1] * 20,
                               velocity=[0.0] * 20, effort=[0.0] * 20)
        elif topic == "camera/image/compressed":
            noise = np.random.default_rng(1).integers(0, 255, 7000, dtype=np.uint8)
            msg = schemas.make(typename, header=schemas.header(), format="jpeg", data=noise)
        else:
            msg = schemas.make(typename)
        out[topic] = schemas.encode(msg)
    return out


def feeder_worker(endpoint: str) -> None:
    """Publishes the 11 robots until stdin closes; joint_states carry the send time as their header stamp."""
    session = open_session(BusConfig(connect=[endpoint]))
    payloads = _payloads()
    joint_states = bytearray(payloads["joint_states"])  # CDR: 4 bytes encapsulation, then stamp sec, nanosec
    publishers = {(r, t): session.declare_publisher(topic_key(r, t)) for r in ROBOTS for t in DEMO_RATES}
    every = {t: max(1, round(TICK_HZ / hz)) for t, hz in DEMO_RATES.items()}
    stop = threading.Event()

    def until_stdin_closes() -> None:
        sys.stdin.read()
        stop.set()

    threading.Thread(target=until_stdin_closes, daemon=True).start()
    sent, tick, next_tick = 0, 0, time.monotonic()
    while not stop.is_set():
        for topic, n in every.items():
            if (tick + hash(topic)) % n:  # topics spread over the ticks, as independent nodes are
                continue
            for robot in ROBOTS:
                if topic == "joint_states":
                    now = time.time_ns()
                    struct.pack_into("<iI", joint_states, 4, now // 10**9, now % 10**9)
                    publishers[(robot, topic)].put(bytes(joint_states))
                else:
                    publishers[(robot, topic)].put(payloads[topic])
                sent += 1
        tick += 1
        next_tick += 1.0 / TICK_HZ
        time.sleep(max(0.0, next_tick - time.monotonic()))
    print(json.dumps({"sent": sent}), flush=True)
    session.close()


class Feeder:
    def __init__(self, endpoint: str) -> None:
        self.proc = subprocess.Popen([sys.executable, __file__, "--feeder-worker", endpoint], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, text=True, cwd=REPO)

    def __enter__(self) -> Feeder:
        return self

    def __exit__(self, *_: object) -> None:
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.close()
        print(f"  feeder: {self.proc.stdout.readline().strip()}")
        self.proc.wait(10)


# -- the server -------------------------------------------------------------------------------------------------
class Server:
    """``python -m server`` on the bench's router, with or without the Foxglove endpoint."""

    def __init__(self, endpoint: str, foxglove: bool, folder: Path) -> None:
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.log = folder / f"server-{self.port}.log"
        args = ["--foxglove-port", str(free_port())] if foxglove else ["--no-foxglove"]
        with self.log.open("wb") as out:
            self.proc = subprocess.Popen([sys.executable, "-m", "server", "--port", str(self.port), "--connect",
                                          endpoint, "--no-telemetry", "--no-auto-record", "--recordings",
                                          str(folder), "--log-level", "WARNING", *args], cwd=REPO, stdout=out,
                                         stderr=subprocess.STDOUT, env=dict(os.environ, PYTHONUNBUFFERED="1"))
        wait_for(self._up, timeout=60, interval=0.2, what="server up")
        self.foxglove_url = (wait_for(lambda: foxglove_url(self.log.read_text()), timeout=30) or "") if foxglove else ""
        self.ps = psutil.Process(self.proc.pid)

    def _up(self) -> bool:
        if self.proc.poll() is not None:
            raise RuntimeError(f"server exited: {self.log.read_text()[-2000:]}")
        try:
            return httpx.get(f"{self.url}/api/config", timeout=1).status_code == 200
        except httpx.HTTPError:
            return False

    def published(self) -> int:
        return int(httpx.get(f"{self.url}/api/hub", timeout=10).json()["published"])

    def close(self) -> None:
        self.proc.terminate()
        self.proc.wait(15)


def measure(server: Server, seconds: float, client: Any = None) -> dict[str, Any]:
    """Server CPU (% of one core) and hub rate over ``seconds``, while ``client()`` (if any) runs."""
    result: dict[str, Any] = {}
    if client is not None:
        thread = threading.Thread(target=lambda: result.update(client=client()), daemon=True)
        thread.start()
        time.sleep(1.5)  # connected and subscribed
    server.ps.cpu_percent(None)
    hub0, t0 = server.published(), time.monotonic()
    time.sleep(seconds if client is None else max(1.0, seconds - 2.5))
    result["cpu"] = server.ps.cpu_percent(None)
    result["hub_msgs_per_s"] = (server.published() - hub0) / (time.monotonic() - t0)
    if client is not None:
        thread.join(seconds + 60)
    return result


def foxglove_clients(url: str, n: int, seconds: float, subprotocol: str = "foxglove.sdk.v1") -> dict[str, Any]:
    return run_client("latency", url, "--clients", str(n), "--seconds", str(seconds), "--subprotocol", subprotocol,
                      timeout=seconds + 60)


def dashboard_latency(url: str, seconds: float) -> list[float]:
    """The baseline: the dashboard's own /ws client on joint_states (bench/server.py's client), delays in ms."""
    spec = importlib.util.spec_from_file_location("bench_server", REPO / "bench" / "server.py")
    assert spec is not None and spec.loader is not None
    bench_server = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench_server)
    got = bench_server.run_clients(url.replace("http://", "ws://") + "/ws", 1, seconds, "joint_states", True,
                                   lambda stop: stop.wait())
    return sorted(d * 1000 for d in got["delays"])


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--feeder-worker":
        feeder_worker(sys.argv[2])
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=8.0)
    parser.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    args = parser.parse_args()
    if args.smoke:
        args.seconds = 1.0
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = open_router([endpoint])
    s = args.seconds
    try:
        with tempfile.TemporaryDirectory(prefix="bench-foxglove-") as tmp, Feeder(endpoint):
            base = Server(endpoint, False, Path(tmp))
            try:
                wait_for(lambda: base.published() > 1000, timeout=30, interval=0.2, what="the feed reaches the hub")
                without = measure(base, s)
                ws_delays = dashboard_latency(base.url, s)
            finally:
                base.close()
            print(f"without the endpoint: server CPU {without['cpu']:.0f} % of a core, hub "
                  f"{without['hub_msgs_per_s']:.0f} msg/s; dashboard /ws joint_states latency p50 "
                  f"{statistics.median(ws_delays):.2f} ms")
            server = Server(endpoint, True, Path(tmp))
            try:
                wait_for(lambda: server.published() > 1000, timeout=30, interval=0.2, what="the feed reaches the hub")
                idle = measure(server, s)
                runs: dict[Any, dict[str, Any]] = {
                    n: measure(server, s, lambda n=n: foxglove_clients(server.foxglove_url, n, s)) for n in (1, 5)}
                runs["1 (foxglove.websocket.v1)"] = measure(server, s, lambda: foxglove_clients(
                    server.foxglove_url, 1, s, "foxglove.websocket.v1"))
            finally:
                server.close()
        print(f"with the endpoint, no client: server CPU {idle['cpu']:.0f} %")
        for n, run in runs.items():
            got, fed = run["client"], run["hub_msgs_per_s"]
            kept = all(rate >= 0.95 * fed for rate in got["stream_msgs_per_s"])
            print(f"{n} Foxglove client(s): server CPU {run['cpu']:.0f} %, hub {fed:.0f} msg/s, delivered "
                  f"{sum(got['msgs_per_s']):.0f} msg/s in total (per client min {min(got['msgs_per_s']):.0f}), "
                  f"every client kept up: {'yes' if kept else 'NO'}; joint_states latency p50 {got['p50_ms']:.2f} ms "
                  f"p99 {got['p99_ms']:.2f} ms ({got['timed']} timed)")
        one, five, older = runs[1], runs[5], runs["1 (foxglove.websocket.v1)"]
        ws_p50 = statistics.median(ws_delays)
        overhead_1, overhead_5 = one["cpu"] - without["cpu"], five["cpu"] - without["cpu"]
        print(f"latency against the dashboard's /ws client: {one['client']['p50_ms'] / ws_p50:.2f}x; CPU overhead "
              f"{overhead_1:.0f} (1 client) / {overhead_5:.0f} (5 clients) points of a core over "
              f"{without['cpu']:.0f} %")
        min_ratio = min(min(r["client"]["stream_msgs_per_s"]) / r["hub_msgs_per_s"] for r in runs.values())
        print(f"RESULT foxglove msgs_per_s_1={sum(one['client']['msgs_per_s']):.0f} "
              f"msgs_per_s_5={sum(five['client']['msgs_per_s']):.0f} latency_p50_ms={one['client']['p50_ms']:.2f} "
              f"latency_p99_ms={one['client']['p99_ms']:.2f} cpu_overhead_pct={overhead_1:.1f} "
              f"cpu_overhead_5_pct={overhead_5:.1f} fed_msgs_per_s={one['hub_msgs_per_s']:.0f} "
              f"min_client_share={min_ratio:.3f} ws_latency_p50_ms={ws_p50:.2f} "
              f"msgs_per_s_v1={sum(older['client']['msgs_per_s']):.0f} "
              f"latency_p50_v1_ms={older['client']['p50_ms']:.2f} latency_p99_v1_ms={older['client']['p99_ms']:.2f} "
              f"cpu_overhead_v1_pct={older['cpu'] - without['cpu']:.1f}")
    finally:
        router.close()


if __name__ == "__main__":
    main()
