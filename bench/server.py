"""Dashboard server throughput and latency: UDP telemetry -> hub -> WebSocket clients, and the field view's frame rate.

    python bench/server.py [--seconds 5] [--no-browser] [--no-live]

The server runs as its own process (``python -m server``, telemetry on a free UDP port, joined to a Zenoh
router in this process); 11 simulated robots' telemetry comes from a third process that writes real
authenticated datagrams (``wire.telemetry.datagram``: stream tables, AES-GCM, sequence numbers)
into the server's UDP port; the WebSocket clients run in a fourth. Figures:
- hub_msgs_per_s: messages/s the hub took in from UDP telemetry while 11 robots flood robot_state;
- ws1_msgs_per_s / ws10_msgs_per_s: messages/s delivered to 1 client / to 10 clients in total, same flood;
- latency_p50_ms / p99: robot send (header stamp) -> WebSocket client, telemetry joint_states of 11 robots at
  100 Hz each (1,100 msg/s);
- field_fps: frames/s the field view draws in chromium with 11 robots moving (telemetry position, 30 Hz each, thinned
  to 15 Hz for the page), from the panel's own frame counter; the panel draws on every animation frame;
- live_hub_msgs_per_s (unless --no-live): the same flood over live Zenoh instead of telemetry.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import os
import socket
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
from schemas.messages import Position2D, RobotControlState
from schemas.std import Header, JointState, Pose2D, Time
from server.protocol import unbatch
from tests.support import free_port
from wire.keys import topic_key
from wire.telemetry import datagram as tdg

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


# -- the telemetry process: 11 robots' datagrams into the server's UDP port ------------------------------------
STREAM_ID = 1


def _stamp_now() -> Any:
    t = time.time_ns()
    return schemas.make(Header, stamp=schemas.make(Time, sec=t // 10**9,
                                                                  nanosec=t % 10**9))


STATE = schemas.encode(schemas.make(RobotControlState, state=10))
JOINTS = [f"joint{i}" for i in range(20)]


def _payload(kind: str, i: int, t: float) -> bytes:
    """Robot i's CDR message: robot_state (flood), joint_states stamped now (latency) or a moving position."""
    if kind == "robot_state":
        return STATE
    if kind == "joint_states":
        return schemas.encode(schemas.make(JointState, header=_stamp_now(), name=JOINTS,
                                           position=[0.1] * 20))
    pose = schemas.make(Pose2D, x=3.5 * math.cos(t * 0.5 + i), y=2.5 * math.sin(t + i), theta=t + i)
    return schemas.encode(schemas.make(Position2D, header=_stamp_now(), pose=pose,
                                       confidence=0.8))


def telemetry_worker(argv: list[str]) -> None:
    """Sends ``topic`` for 11 robots at ``hz`` each (0: as fast as it can) until stdin closes."""
    port, topic, hz = int(argv[0]), argv[1], float(argv[2])
    typename = schemas.codec.full_name(schemas.TOPICS[topic].type)
    schema = schemas.codec.schema_hash(typename)
    key = tdg.load_key(None)
    writers = [tdg.DatagramWriter(key, robot) for robot in ROBOTS]
    info = tdg.StreamInfo(STREAM_ID, topic, typename, schema, int(schemas.TOPICS[topic].priority), hz)
    tables = tdg.encode_stream_tables([info], 100_000_000)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 4 << 20)
    sock.connect(("127.0.0.1", port))
    stop = threading.Event()

    def until_stdin_closes() -> None:
        sys.stdin.read()
        stop.set()

    threading.Thread(target=until_stdin_closes, daemon=True).start()
    sent = errors = 0
    next_table = next_tick = t0 = time.monotonic()
    while not stop.is_set():
        now = time.monotonic()
        if now >= next_table:  # the receiver learns stream ids from the table, as from a real sender
            for writer in writers:
                for body in tables:
                    sock.send(writer.message(tdg.Kind.STREAM_TABLE, tdg.TABLE_STREAM, tdg.TABLE_HASH, body)[0])
            next_table = now + 0.5
        for i, writer in enumerate(writers):
            for data in writer.message(tdg.Kind.MESSAGE, STREAM_ID, schema, _payload(topic, i, now - t0)):
                try:
                    sock.send(data)
                    sent += 1
                except OSError:  # a full socket buffer: lost like on air
                    errors += 1
            if hz > 0:  # robots are not synchronized: each sends at its own phase
                next_tick += 1.0 / (hz * len(writers))
                time.sleep(max(0.0, next_tick - time.monotonic()))
    print(json.dumps({"sent": sent, "errors": errors}), flush=True)


class Telemetry:
    """The telemetry process, as a context manager."""

    def __init__(self, port: int, topic: str, hz: float) -> None:
        self.proc = subprocess.Popen([sys.executable, __file__, "--telemetry-worker", str(port), topic, str(hz)],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, cwd=REPO)
        self.result: dict[str, Any] = {}

    def __enter__(self) -> Telemetry:
        return self

    def __exit__(self, *_: object) -> None:
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.close()
        line = self.proc.stdout.readline()
        self.result = json.loads(line) if line else {}
        print(f"  telemetry sender: {self.result}")
        self.proc.wait(10)


# -- publishers in this process ---------------------------------------------------------------------------
def flood(session: Any, stop: threading.Event) -> None:
    """robot_state of 11 robots as fast as Python can put them."""
    payload = schemas.encode(schemas.make(RobotControlState, state=10))
    pubs = [session.declare_publisher(topic_key(r, "robot_state")) for r in ROBOTS]
    while not stop.is_set():
        for pub in pubs:
            pub.put(payload)
    for pub in pubs:
        pub.undeclare()


# -- the browser --------------------------------------------------------------------------------------------
def field_fps(url: str, seconds: float) -> tuple[float, float]:
    """(frames/s the field view drew while 11 robots move, ms per draw), counted by the panel itself."""
    from playwright.sync_api import TimeoutError as PlaywrightTimeout
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path="/usr/bin/chromium", args=[
            "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update"])
        page = browser.new_page(bypass_csp=True, viewport={"width": 1600, "height": 1000})
        # the match preset shows the field view first (the page's default, the lab's, no longer has it); the field
        # view draws only while on screen
        page.goto(f"{url}/?preset=match")
        field = page.locator('[data-panel="field"]')
        field.wait_for(timeout=60_000)
        field.scroll_into_view_if_needed()
        try:
            page.wait_for_function("window.pitchside?.fieldView?.drawn?.length >= 11", timeout=60_000)
        except PlaywrightTimeout:
            seen = page.evaluate("""() => ({ drawn: window.pitchside?.fieldView?.drawn?.map((r) => r.id),
                running: window.pitchside?.fieldView?.running, frames: window.pitchside?.fieldView?.frames,
                box: document.querySelector('[data-panel="field"]')?.getBoundingClientRect()?.toJSON() })""")
            raise SystemExit(f"the field view did not draw 11 robots within 60 s: {seen}") from None
        # the panel's own frame counter over `seconds` of the page's clock, and the animation frames the page got
        got = page.evaluate("""(ms) => new Promise((done) => {
            const fv = window.pitchside.fieldView, f0 = fv.frames, t0 = performance.now();
            let raf = 0;
            const tick = () => { raf++; if (performance.now() - t0 < ms) requestAnimationFrame(tick);
                else done({ frames: fv.frames - f0, raf, s: (performance.now() - t0) / 1000 }); };
            requestAnimationFrame(tick); })""", seconds * 1000)
        draw_ms = page.evaluate("window.pitchside.fieldView.drawMs")
        print(f"  browser animation frames: {got['raf'] / got['s']:.1f}/s; field view drew {got['frames']} frames in "
              f"{got['s']:.1f} s; one draw (11 robots) takes {draw_ms:.2f} ms")
        browser.close()
    return got["frames"] / got["s"], draw_ms


def _wait_up(url: str) -> None:
    deadline = time.monotonic() + 60
    while True:
        try:
            if httpx.get(f"{url}/api/config", timeout=1).status_code == 200:
                return
        except httpx.HTTPError:
            pass
        if time.monotonic() > deadline:
            raise SystemExit("server did not start")
        time.sleep(0.1)


def throughput(url: str, ws_url: str, n: int, seconds: float, start_flood: Any) -> tuple[float, float, list[int]]:
    """(hub intake msg/s, msg/s delivered to n clients in total, per client) while ``start_flood`` runs."""
    marks: list[tuple[float, int]] = []

    def hub_published() -> int:
        return int(httpx.get(f"{url}/api/hub", timeout=10).json()["published"])

    def during(stop: threading.Event) -> None:
        with start_flood():
            time.sleep(0.5)
            marks.append((time.monotonic(), hub_published()))
            stop.wait()
            marks.append((time.monotonic(), hub_published()))

    got = run_clients(ws_url, n, seconds, "robot_state", False, during)
    (t0, p0), (t1, p1) = marks
    return (p1 - p0) / (t1 - t0), got["total"] / seconds, got["per_client"]


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--clients-worker":
        client_worker(sys.argv[2:])
        return
    if len(sys.argv) > 1 and sys.argv[1] == "--telemetry-worker":
        telemetry_worker(sys.argv[2:])
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--no-browser", action="store_true")
    parser.add_argument("--no-live", action="store_true", help="skip the live Zenoh flood")
    parser.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    args = parser.parse_args()
    if args.smoke:
        args.seconds = 1.0
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = open_router([endpoint])
    port, udp = free_port(), free_port(socket.SOCK_DGRAM)
    server = subprocess.Popen([sys.executable, "-m", "server", "--port", str(port), "--connect", endpoint,
                               "--telemetry-host", "127.0.0.1", "--telemetry-port", str(udp),
                               "--log-level", "WARNING"], cwd=REPO, env=dict(os.environ, PYTHONUNBUFFERED="1"))
    session = open_session(BusConfig(connect=[endpoint]))
    url, ws_url = f"http://127.0.0.1:{port}", f"ws://127.0.0.1:{port}/ws"
    try:
        _wait_up(url)
        results: dict[str, float] = {}
        for n in (1, 10):
            hub, ws, per_client = throughput(url, ws_url, n, args.seconds, lambda: Telemetry(udp, "robot_state", 0))
            results[f"hub{n}"], results[f"ws{n}"] = hub, ws
            spread = f" (per client min {min(per_client)} max {max(per_client)})" if n > 1 else ""
            print(f"telemetry flood, {n:2d} client(s): hub took {hub:8.0f} msg/s, clients got {ws:8.0f} msg/s in "
                  f"total{spread}")
        telemetry = next(s for s in httpx.get(f"{url}/api/sources").json() if s["name"] == "telemetry")
        print("  telemetry source counters:", {k: v for k, v in telemetry.items() if isinstance(v, int | float)})
        time.sleep(1.0)  # let the server drain the flood

        with Telemetry(udp, "joint_states", 100.0):
            time.sleep(1.0)  # the stream table is known, the stream runs
            got = run_clients(ws_url, 1, args.seconds, "joint_states", True, lambda stop: stop.wait())
        delays = sorted(d * 1000 for d in got["delays"])
        p50 = statistics.median(delays)
        p99 = delays[int(0.99 * (len(delays) - 1))]
        print(f"latency, telemetry joint_states of 11 robots x 100 Hz: {len(delays)} messages, p50 {p50:.2f} ms, "
              f"p99 {p99:.2f} ms")

        live = ""
        if not args.no_live:
            class LiveFlood:
                def __enter__(self) -> None:
                    self.stop = threading.Event()
                    self.thread = threading.Thread(target=flood, args=(session, self.stop), daemon=True)
                    self.thread.start()

                def __exit__(self, *_: object) -> None:
                    self.stop.set()
                    self.thread.join(5)

            hub, ws, _ = throughput(url, ws_url, 1, args.seconds, LiveFlood)
            print(f"live Zenoh flood, 1 client: hub took {hub:8.0f} msg/s, client got {ws:8.0f} msg/s")
            live = f" live_hub_msgs_per_s={hub:.0f}"
            time.sleep(1.0)

        fps = draw_ms = float("nan")
        if not args.no_browser:
            with Telemetry(udp, "position", 30.0):
                fps, draw_ms = field_fps(url, args.seconds)
            print(f"field view with 11 robots moving at 30 Hz (telemetry): {fps:.1f} frames/s")
        print(f"RESULT server hub_msgs_per_s={results['hub1']:.0f} ws1_msgs_per_s={results['ws1']:.0f} "
              f"ws10_msgs_per_s={results['ws10']:.0f} latency_p50_ms={p50:.2f} latency_p99_ms={p99:.2f} "
              f"field_fps={fps:.1f} field_draw_ms={draw_ms:.2f}{live}")
    finally:
        session.close()
        server.terminate()
        server.wait(10)
        router.close()


if __name__ == "__main__":
    main()
