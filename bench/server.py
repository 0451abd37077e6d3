"""Dashboard server throughput and latency: Zenoh -> hub -> WebSocket clients, and the field view's frame rate.

    python bench/server.py [--seconds 5] [--no-browser]

The server runs as its own process (``python -m server``) joined to a Zenoh router in this process; the
WebSocket clients run in a third process. Figures:
- hub_msgs_per_s: messages/s the hub took in while a publisher floods 11 robots' robot_state;
- ws1_msgs_per_s / ws10_msgs_per_s: messages/s delivered to 1 client / to 10 clients in total, same flood;
- latency_p50_ms / p99: publish -> browser-side client, joint_states of 11 robots at 100 Hz each;
- field_fps: frames/s the field view draws in chromium with 11 robots moving at 30 Hz.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import httpx

import schemas
from robot_nodes.runtime import BusConfig, open_router, open_session
from robot_nodes.runtime.keys import topic_key
from server.protocol import unbatch
from tests.conftest import free_port

REPO = Path(__file__).resolve().parents[1]
ROBOTS = [f"r{i}" for i in range(1, 12)]


# -- the client process -------------------------------------------------------------------------------------
async def _clients(url: str, n: int, seconds: float, topic: str, latency: bool) -> dict[str, Any]:
    import websockets

    counts = [0] * n
    delays: list[float] = []
    ready = asyncio.Event()
    start_at: list[float] = []

    async def one(i: int) -> None:
        async with websockets.connect(url, max_size=None) as ws:
            await ws.send(json.dumps({"op": "subscribe", "robot": "*", "topic": topic}))
            connected.append(i)
            if len(connected) == n:
                ready.set()
            while True:
                raw = await ws.recv()
                if not start_at or not isinstance(raw, str):
                    continue
                if latency:
                    now = time.time()
                    frames = [f for f in unbatch(json.loads(raw)) if f["type"] == "msg"]
                    delays.extend(now - f["stamp"] for f in frames)
                    counts[i] += len(frames)
                else:
                    counts[i] += raw.count('{"type":"msg"')

    connected: list[int] = []
    tasks = [asyncio.create_task(one(i)) for i in range(n)]
    await asyncio.wait_for(ready.wait(), 30)
    print("READY", flush=True)
    await asyncio.to_thread(sys.stdin.readline)  # the parent starts the flood, then says go
    start_at.append(time.monotonic())
    await asyncio.sleep(seconds)
    total = sum(counts)
    for t in tasks:
        t.cancel()
    await asyncio.gather(*tasks, return_exceptions=True)
    return {"total": total, "per_client": counts, "delays": delays}


def client_worker(argv: list[str]) -> None:
    url, n, seconds, topic, latency = argv[0], int(argv[1]), float(argv[2]), argv[3], argv[4] == "1"
    print(json.dumps(asyncio.run(_clients(url, n, seconds, topic, latency))), flush=True)


def run_clients(url: str, n: int, seconds: float, topic: str, latency: bool, during: Any) -> dict[str, Any]:
    """Starts the client process, waits until all are subscribed, runs ``during`` while they count."""
    proc = subprocess.Popen([sys.executable, __file__, "--clients-worker", url, str(n), str(seconds), topic,
                             "1" if latency else "0"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                            cwd=REPO)
    assert proc.stdout is not None and proc.stdin is not None
    line = proc.stdout.readline()
    if "READY" not in line:
        raise RuntimeError(f"clients did not start: {line!r}")
    stop = threading.Event()
    worker = threading.Thread(target=during, args=(stop,), daemon=True)
    worker.start()
    time.sleep(0.5)  # the flood reaches steady state before the clients start counting
    proc.stdin.write("go\n")
    proc.stdin.flush()
    result = json.loads(proc.stdout.readline())
    stop.set()
    worker.join(10)
    proc.wait(10)
    return result


# -- publishers in this process ---------------------------------------------------------------------------
def flood(session: Any, stop: threading.Event) -> None:
    """robot_state of 11 robots as fast as Python can put them."""
    payload = schemas.encode(schemas.make("humanoid_league_msgs/msg/RobotControlState", state=10))
    pubs = [session.declare_publisher(topic_key(r, "robot_state")) for r in ROBOTS]
    while not stop.is_set():
        for pub in pubs:
            pub.put(payload)
    for pub in pubs:
        pub.undeclare()


def joint_states_at(session: Any, hz: float, stop: threading.Event) -> None:
    """joint_states of 11 robots at ``hz`` each, stamped at publish time."""
    pubs = [session.declare_publisher(topic_key(r, "joint_states")) for r in ROBOTS]
    names = [f"joint{i}" for i in range(20)]
    period = 1.0 / hz
    next_t = time.monotonic()
    while not stop.is_set():
        for pub in pubs:
            t = time.time_ns()
            stamp = schemas.make("builtin_interfaces/msg/Time", sec=t // 10**9, nanosec=t % 10**9)
            msg = schemas.make("sensor_msgs/msg/JointState", header=schemas.make("std_msgs/msg/Header", stamp=stamp),
                               name=names, position=[0.1] * 20)
            pub.put(schemas.encode(msg))
        next_t += period
        time.sleep(max(0.0, next_t - time.monotonic()))
    for pub in pubs:
        pub.undeclare()


def positions_at(session: Any, hz: float, stop: threading.Event) -> None:
    import math

    pubs = [session.declare_publisher(topic_key(r, "position")) for r in ROBOTS]
    t0 = time.monotonic()
    while not stop.is_set():
        t = time.monotonic() - t0
        for i, pub in enumerate(pubs):
            pose = schemas.make("geometry_msgs/msg/Pose2D", x=3.5 * math.cos(t * 0.5 + i), y=2.5 * math.sin(t + i),
                                theta=t + i)
            pub.put(schemas.encode(schemas.make("humanoid_league_msgs/msg/Position2D", pose=pose, confidence=0.8)))
        time.sleep(1.0 / hz)


# -- the browser --------------------------------------------------------------------------------------------
def field_fps(url: str, seconds: float) -> float:
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path="/usr/bin/chromium", args=[
            "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update"])
        page = browser.new_page(viewport={"width": 1600, "height": 1000})
        page.goto(url)
        page.wait_for_function("window.pitchside?.fieldView?.drawn?.length === 11", timeout=30_000)
        f0 = page.evaluate("window.pitchside.fieldView.frames")
        time.sleep(seconds)
        f1 = page.evaluate("window.pitchside.fieldView.frames")
        browser.close()
    return (f1 - f0) / seconds


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--clients-worker":
        client_worker(sys.argv[2:])
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--no-browser", action="store_true")
    args = parser.parse_args()
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = open_router([endpoint])
    port = free_port()
    server = subprocess.Popen([sys.executable, "-m", "server", "--port", str(port), "--connect", endpoint,
                               "--no-telemetry", "--log-level", "WARNING"], cwd=REPO,
                              env=dict(os.environ, PYTHONUNBUFFERED="1"))
    session = open_session(BusConfig(connect=[endpoint]))
    url, ws_url = f"http://127.0.0.1:{port}", f"ws://127.0.0.1:{port}/ws"
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                if httpx.get(f"{url}/api/config", timeout=1).status_code == 200:
                    break
            except httpx.HTTPError:
                pass
            if time.monotonic() > deadline:
                raise SystemExit("server did not start")
            time.sleep(0.1)

        def hub_published() -> int:
            return int(httpx.get(f"{url}/api/hub", timeout=10).json()["published"])

        results: dict[str, float] = {}
        for n in (1, 10):
            marks: list[tuple[float, int]] = []

            def during(stop: threading.Event, marks: list[tuple[float, int]] = marks) -> None:
                flooding = threading.Thread(target=flood, args=(session, stop), daemon=True)
                flooding.start()
                time.sleep(0.5)
                marks.append((time.monotonic(), hub_published()))
                stop.wait()
                marks.append((time.monotonic(), hub_published()))
                flooding.join(5)

            got = run_clients(ws_url, n, args.seconds, "robot_state", False, during)
            (t0, p0), (t1, p1) = marks
            results[f"hub{n}"] = (p1 - p0) / (t1 - t0)
            results[f"ws{n}"] = got["total"] / args.seconds
            spread = f"min {min(got['per_client'])} max {max(got['per_client'])}" if n > 1 else ""
            print(f"{n:2d} client(s): hub took {results[f'hub{n}']:9.0f} msg/s, clients got "
                  f"{results[f'ws{n}']:9.0f} msg/s in total {spread}")
        time.sleep(1.0)  # let the server drain the flood

        got = run_clients(ws_url, 1, args.seconds, "joint_states", True,
                          lambda stop: joint_states_at(session, 100.0, stop))
        delays = sorted(d * 1000 for d in got["delays"])
        p50 = statistics.median(delays)
        p99 = delays[int(0.99 * (len(delays) - 1))]
        print(f"latency, 11 robots x 100 Hz joint_states: {len(delays)} messages, p50 {p50:.2f} ms, p99 {p99:.2f} ms")

        fps = float("nan")
        if not args.no_browser:
            stop = threading.Event()
            mover = threading.Thread(target=positions_at, args=(session, 30.0, stop), daemon=True)
            mover.start()
            try:
                fps = field_fps(url, args.seconds)
            finally:
                stop.set()
                mover.join(5)
            print(f"field view with 11 robots at 30 Hz: {fps:.1f} frames/s")
        print(f"RESULT server hub_msgs_per_s={results['hub1']:.0f} ws1_msgs_per_s={results['ws1']:.0f} "
              f"ws10_msgs_per_s={results['ws10']:.0f} latency_p50_ms={p50:.2f} latency_p99_ms={p99:.2f} "
              f"field_fps={fps:.1f}")
    finally:
        session.close()
        server.terminate()
        server.wait(10)
        router.close()


if __name__ == "__main__":
    main()
