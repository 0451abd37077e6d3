"""Faults at the venue: SIGKILL each robot node, the simulation and the server while data flows and a recording runs.

    python bench/faults.py [--robots 1] [--quick]

Runs the real demo (``pitchside demo``: world, every robot's nodes, simulated GameController, server, each a process
its launcher supervises), waits until data flows, starts a manual recording (the match recording starts by itself
when the simulated game leaves INITIAL), then kills one process at a time with SIGKILL, waits until it is back and
the robot is CONTROLLABLE again, lets the stack settle, and kills the next. Per victim:

- restarted_s: kill -> the launcher's new process exists;
- flows_s: kill -> the victim's own data arrives fresh (from the new process), seen where a user sees it:
  on the team's Zenoh bus for the nodes (hcm: robot_state, pause: paused, walking: walking_active, game_controller:
  gamestate, animation and speaker: their diagnostics with an uptime younger than the kill, world: every robot's
  joint_states), at the dashboard for telemetry (overview datagrams, source telemetry, over the WebSocket) and for
  the server (a new WebSocket delivers fresh joint_states);
- controllable_s: kill -> every robot's robot_state says CONTROLLABLE again;
- lost_s: seconds of recording lost, on the bus's clock. Every joint_states and diagnostics message (each carries a
  stamp, so its bytes are unique) seen on the bus is looked up in the manual recording; the longest run of missing
  messages, from the last one recorded before it to the first one after, minus the stream's usual interval, is
  lost. What a dead node did not publish is not missing, and a server that received late but wrote everything lost
  nothing. Server and recorder: the kill time minus the last message before it that made it into the file (what
  reached the recorder but not the disk); gap_s: kill -> first message recorded after it (manual and match recording
  each), the time nobody could record. The recorder is a process of its own beside the dashboard, each with a warm
  spare (server.standby): a dashboard kill should leave the recording untouched (gap_s about one message interval),
  a recorder kill cost at most its unflushed buffer (lost_s < 0.5);
- crashes: processes other than the victim that died or restarted meanwhile, and victims never brought back.

The baseline, measured in the same run on the same loaded machine: a minimal node (tests.proc_nodes talker) from
spawn to its first message on the bus (median of 3), the floor any restarted Python node can reach.
"""

from __future__ import annotations

import argparse
import bisect
import contextlib
import itertools
import os
import re
import secrets
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections import defaultdict
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import httpx
import psutil

import schemas
from robot_nodes.catalog import NODE_MODULES
from robot_nodes.runtime import BusConfig, open_session
from schemas.logs import LogError, LogReader
from schemas.messages import RobotControlState
from schemas.std import DiagnosticArray
from tests.running_demo import DashboardObserver, RunningDemo, running_demo
from tests.support import REPO
from tests.waiting import wait_for
from wire import keys

ROUTER = re.compile(r"Zenoh router (tcp/[0-9.]+:\d+)")
CONTROLLABLE = RobotControlState.CONTROLLABLE
NODE_OF_MODULE = {module: name for name, module in NODE_MODULES.items()}
# the victim's own topic on the bus; None: only its diagnostics tell it is alive
NODE_TOPIC: dict[str, str | None] = {"hcm": "robot_state", "animation": None, "pause": "paused", "speaker": None,
                                     "walking": "walking_active", "game_controller": "gamestate", "telemetry": None}
BUS_TOPICS = ("joint_states", "robot_state", "paused", "walking_active", "gamestate", "diagnostics")
COMPARED = ("joint_states", "diagnostics")  # stamped streams (unique bytes) looked up in the recording
BACK_TIMEOUT_S = 30.0


def now() -> float:
    return time.time()


# -- what flows -----------------------------------------------------------------------------------------------
class BusWatch:
    """Arrival times (wall clock) of the robots' topics on the team's Zenoh bus, as another dashboard would see them."""

    def __init__(self, endpoint: str) -> None:
        self.arrivals: dict[tuple[str, str], list[float]] = defaultdict(list)
        self.states: dict[str, list[tuple[float, int]]] = defaultdict(list)  # robot -> (arrival, HCM state)
        self.diagnostics: dict[tuple[str, str], list[tuple[float, float]]] = defaultdict(list)  # (arrival, start)
        self.payloads: dict[tuple[str, str], list[tuple[float, bytes]]] = defaultdict(list)  # COMPARED streams
        self.session = open_session(BusConfig(connect=[endpoint]))
        self._subs = [self.session.declare_subscriber(keys.topic_key("*", topic), self._on_sample)
                      for topic in BUS_TOPICS]

    def _on_sample(self, sample: Any) -> None:
        t = now()
        robot, topic = keys.split_topic_key(str(sample.key_expr))
        self.arrivals[(robot, topic)].append(t)
        if topic in COMPARED:
            self.payloads[(robot, topic)].append((t, sample.payload.to_bytes()))
        if topic == "robot_state":
            state = schemas.decode(sample.payload.to_bytes(), RobotControlState)
            self.states[robot].append((t, int(state.state)))
        elif topic == "diagnostics":
            diagnostics = schemas.decode(sample.payload.to_bytes(), DiagnosticArray)
            for status in diagnostics.status:
                values = {kv.key: kv.value for kv in status.values}
                if "uptime_s" in values:
                    node = status.name.rsplit("/", 1)[-1]
                    self.diagnostics[(robot, node)].append((t, t - float(values["uptime_s"])))

    def first_after(self, robot: str, topic: str, t0: float) -> float | None:
        times = self.arrivals[(robot, topic)]  # appended as they come: in order
        i = bisect.bisect_right(times, t0)
        return times[i] if i < len(times) else None

    def first_started_after(self, robot: str, node: str, t0: float) -> float | None:
        """First diagnostics of a node instance started after t0 (a restarted node, not the killed one)."""
        return next((t for t, started in self.diagnostics[(robot, node)] if t > t0 and started > t0), None)

    def controllable_since(self, robot: str, t0: float) -> float | None:
        """First CONTROLLABLE after t0 that is not followed by another state (the robot is back for good)."""
        since = None
        for t, state in self.states[robot]:
            if t <= t0:
                continue
            since = (since or t) if state == CONTROLLABLE else None
        return since

    def fresh(self, robot: str, topic: str, within: float = 0.5) -> bool:
        times = self.arrivals[(robot, topic)]
        return bool(times) and now() - times[-1] < within

    def close(self) -> None:
        for sub in self._subs:
            sub.undeclare()
        self.session.close()


@dataclass
class DashboardWatch(DashboardObserver):
    """A WebSocket client of the dashboard that reconnects at once after the server dies; arrivals per stream."""

    arrivals: dict[tuple[str, str, str], list[tuple[float, float]]] = field(
        default_factory=lambda: defaultdict(list))  # (robot, topic, source) -> (arrival, stamp)

    def _run(self) -> None:
        while not self._stop.is_set():
            super()._run()  # returns when the server is gone: try again at once, that is what is measured
            time.sleep(0.02)

    def _seen(self, frame: dict[str, Any]) -> None:
        self.arrivals[(frame["robot"], frame["topic"], frame["source"])].append((now(), float(frame["stamp"])))

    def first_after(self, robot: str, topic: str, source: str, t0: float) -> float | None:
        frames = self.arrivals[(robot, topic, source)]
        start = bisect.bisect_right(frames, t0, key=lambda frame: frame[0])
        return next((t for t, stamp in frames[start:] if stamp > t0), None)


# -- the processes ----------------------------------------------------------------------------------------------
def lock_holders() -> set[int]:
    """The processes holding a file lock now (/proc/locks; a waiting one's line has "->")."""
    holders = set()
    for line in Path("/proc/locks").read_text().splitlines():
        fields = line.split()
        if len(fields) > 4 and "->" not in fields:
            with contextlib.suppress(ValueError):
                holders.add(int(fields[4]))
    return holders


def label_of(cmdline: list[str], pid: int = 0) -> str | None:
    """The launcher's name of a demo process ("world", "robot1/hcm", "server", "recorder", "server-spare", ...)."""
    if "-m" not in cmdline:
        return None
    module = cmdline[cmdline.index("-m") + 1]
    if module == "robot_nodes.sim":
        return "world"
    if module in ("server", "server.recording"):
        role = "server" if module == "server" else "recorder"
        # two copies with --standby-lock: the one holding the lock works, the other is its warm spare
        return role if "--standby-lock" not in cmdline or pid in lock_holders() else f"{role}-spare"
    if module == "robot_nodes.sim.gamecontroller":
        return "gamecontroller"
    node = NODE_OF_MODULE.get(module)
    if node is None or "--robot-id" not in cmdline:
        return None
    return f"{cmdline[cmdline.index('--robot-id') + 1]}/{node}"


def started_at(pid: int) -> float:
    """Wall-clock start of a process to a clock tick (psutil's create_time rounds the boot time to a second)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    since_boot = int(fields[19]) / os.sysconf("SC_CLK_TCK")  # field 22, starttime, counted after "pid (comm)"
    return now() - (time.clock_gettime(time.CLOCK_BOOTTIME) - since_boot)


@dataclass
class ProcessChange:
    at: float
    label: str
    old_pid: int | None
    new_pid: int | None


class ProcessWatch:
    """Polls the demo's supervised processes (its direct children): every pid change, with its time."""

    def __init__(self, root_pid: int) -> None:
        self.root = psutil.Process(root_pid)
        self.pids: dict[str, int] = {}
        self.created: dict[int, float] = {}
        self.changes: list[ProcessChange] = []
        self._lock = threading.Lock()
        self._poll()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="process-watch", daemon=True)
        self._thread.start()

    def _current(self) -> dict[str, int]:
        found = {}
        for child in self.root.children():
            with contextlib.suppress(psutil.Error):
                if child.status() == psutil.STATUS_ZOMBIE:
                    continue  # dead, not yet reaped by the launcher
                label = label_of(child.cmdline(), child.pid)
                if label is not None:
                    found[label] = child.pid
                    self.created.setdefault(child.pid, started_at(child.pid))
        return found

    def _poll(self) -> None:
        current = self._current()
        t = now()
        with self._lock:
            for label in current.keys() | self.pids.keys():
                old, new = self.pids.get(label), current.get(label)
                if old != new and self.pids:
                    self.changes.append(ProcessChange(t, label, old, new))
            self.pids = current

    def _run(self) -> None:
        while not self._stop.wait(0.05):
            with contextlib.suppress(psutil.Error):
                self._poll()

    def pid(self, label: str) -> int | None:
        with self._lock:
            return self.pids.get(label)

    def restarted(self, label: str, old_pid: int) -> tuple[int, float] | None:
        """(new pid, its creation time) once the launcher has started the victim again."""
        pid = self.pid(label)
        return (pid, self.created[pid]) if pid is not None and pid != old_pid else None

    def close(self) -> None:
        self._stop.set()
        self._thread.join(5)


# -- one kill ---------------------------------------------------------------------------------------------------
@dataclass
class Outcome:
    victim: str
    data: str  # what "flows again" means for it
    killed_at: float
    restarted_s: float | None = None
    flows_s: float | None = None
    controllable_s: float | None = None
    lost_s: float | None = None
    gap_s: float | None = None  # server only: kill -> first message of the resumed recordings
    crashed: list[str] = field(default_factory=list)


@dataclass
class Stack:
    demo: RunningDemo
    bus: BusWatch
    dash: DashboardWatch
    procs: ProcessWatch
    robots: list[str]
    token: str
    endpoint: str  # the demo's Zenoh router

    def api(self, method: str, path: str, body: dict[str, Any] | None = None) -> Any:
        response = httpx.request(method, f"{self.demo.url}/api{path}", json=body, timeout=30,
                                 headers={"Authorization": f"Bearer {self.token}"})
        response.raise_for_status()
        return response.json()

    def all_flowing(self) -> bool:
        return all(self.bus.fresh(r, "joint_states") and self.bus.fresh(r, "robot_state")
                   and self.bus.controllable_since(r, now() - 1.0) for r in self.robots)


def flows_probe(stack: Stack, victim: str) -> tuple[str, Callable[[float, float], float | None]]:
    """What "flows again" means for the victim: (description, first(kill time, new process start) -> time)."""
    bus, dash = stack.bus, stack.dash
    if victim == "world":
        def every_robot(_killed: float, started: float) -> float | None:
            times = [bus.first_after(r, "joint_states", started) for r in stack.robots]
            return None if None in times else max(t for t in times if t is not None)
        return "joint_states of every robot (bus)", every_robot
    if victim == "server":
        def dashboard(killed: float, _started: float) -> float | None:
            times = [dash.first_after(r, "joint_states", "live", killed) for r in stack.robots]
            return None if None in times else max(t for t in times if t is not None)
        return "fresh joint_states over a new WebSocket", dashboard
    if victim == "recorder":
        old_pid = stack.procs.pid("recorder")

        def recording_again(_killed: float, _started: float) -> float | None:
            try:
                status = stack.api("GET", "/recordings/status")
            except httpx.HTTPError:
                return None
            process, manual = status.get("process") or {}, status.get("manual") or {}
            fresh = process.get("up") and process.get("pid") != old_pid and manual.get("resumed")
            return now() if fresh else None
        return "the manual recording going on in a new recorder (dashboard's status)", recording_again
    robot, node = victim.split("/")
    topic = NODE_TOPIC[node]
    if node == "telemetry":
        return "overview datagrams at the server (WebSocket)", \
            lambda killed, started: dash.first_after(robot, "overview", "telemetry", started)
    if topic is None:
        return "its diagnostics, from the new process (bus)", \
            lambda killed, started: bus.first_started_after(robot, node, killed)
    return f"{topic} (bus)", lambda killed, started: bus.first_after(robot, topic, started)


def kill_and_wait(stack: Stack, victim: str, settle_s: float) -> Outcome:
    procs = stack.procs
    pid = procs.pid(victim)
    if pid is None:
        raise SystemExit(f"no process {victim} in the demo (found {sorted(procs.pids)})")
    data, first_flow = flows_probe(stack, victim)
    before = dict(procs.pids)
    os.kill(pid, signal.SIGKILL)
    out = Outcome(victim, data, now())
    deadline = time.monotonic() + BACK_TIMEOUT_S
    new: tuple[int, float] | None = None
    while time.monotonic() < deadline:
        new = new or procs.restarted(victim, pid)
        if new is not None:
            out.restarted_s = max(0.0, new[1] - out.killed_at)
            flowed = first_flow(out.killed_at, new[1])
            if flowed is not None:
                out.flows_s = flowed - out.killed_at
                break
        time.sleep(0.02)
    if out.flows_s is None:
        out.crashed.append(f"{victim} not back within {BACK_TIMEOUT_S:.0f} s")
        return out
    with contextlib.suppress(AssertionError):
        wait_for(stack.all_flowing, timeout=BACK_TIMEOUT_S, interval=0.05, what="every robot CONTROLLABLE")
    back = [stack.bus.controllable_since(r, out.killed_at) for r in stack.robots]
    if None not in back:
        out.controllable_s = max(t for t in back if t is not None) - out.killed_at
    time.sleep(settle_s)  # the next kill starts from a calm stack, and this one's aftermath is in the window
    for change in procs.changes:
        # a warm spare taking over and its replacement starting are no crash
        if (change.at >= out.killed_at and change.label != victim and not change.label.endswith("-spare")
                and change.old_pid == before.get(change.label)):
            out.crashed.append(f"{change.label} pid {change.old_pid} -> {change.new_pid}")
    return out


# -- the recording afterwards ---------------------------------------------------------------------------------
def recorded_payloads(files: list[Path]) -> set[bytes]:
    """The CDR bytes of every compared message in the files (a crash-cut file gives its complete chunks)."""
    found: set[bytes] = set()
    for path in files:
        try:
            with LogReader(path) as log:
                found.update(bytes(m.msg) for m in log.messages(topics=list(COMPARED), decode=False))
        except LogError as exc:
            print(f"  {path.name}: {exc}")
    return found


def longest_missing(seen: list[tuple[float, bytes]], recorded: set[bytes], start: float, end: float) -> float:
    """The longest stretch of the bus's messages in [start, end] missing from the recording, minus the usual interval
    (from the last recorded message before the stretch to the first after it; the window's edges stand in)."""
    inside = [(t, data in recorded) for t, data in seen if start <= t <= end]
    times = [t for t, _ in inside]
    usual = statistics.median(b - a for a, b in itertools.pairwise(times)) if len(times) > 2 else 0.0
    longest, last_present, missing = 0.0, start, False
    for t, present in [*inside, (end, True)]:
        if not present:
            missing = True
        elif missing:
            longest, missing = max(longest, t - last_present - usual), False
            last_present = t
        else:
            last_present = t
    return max(0.0, longest)


def node_lost(out: Outcome, recorded: set[bytes], bus: BusWatch) -> float:
    """Seconds of the compared streams, around the kill, that were on the bus but are not in the recording."""
    assert out.flows_s is not None
    start, end = out.killed_at - 1.0, out.killed_at + out.flows_s + 2.0
    return max((longest_missing(seen, recorded, start, end) for seen in bus.payloads.values()), default=0.0)


def server_lost(out: Outcome, recorded: set[bytes], bus: BusWatch) -> tuple[float | None, float | None]:
    """(kill -> back to the last joint_states before it that is in the recording, kill -> first one after it)."""
    seen = sorted((t, data) for (_, topic), series in bus.payloads.items() if topic == "joint_states"
                  for t, data in series)
    kept = [t for t, data in seen if data in recorded]
    before = [t for t in kept if t <= out.killed_at]
    after = [t for t in kept if t > out.killed_at]
    return (out.killed_at - before[-1] if before else None), (after[0] - out.killed_at if after else None)


# -- the baseline -----------------------------------------------------------------------------------------------
def bare_node_start(bus: BusWatch, endpoint: str) -> float:
    """Spawn -> first message of the smallest node there is, on this machine, now."""
    robot = f"base{secrets.randbelow(10**6)}"  # a robot id as the rules want it (at most 12 characters)
    key = keys.topic_key(robot, "joint_states")
    seen = threading.Event()
    sub = bus.session.declare_subscriber(key, lambda _sample: seen.set())
    t0 = now()
    talker = subprocess.Popen([sys.executable, "-m", "tests.proc_nodes", "talker", "--robot-id", robot,
                               "--connect", endpoint, "--set", "rate_hz=100"], cwd=REPO)
    try:
        if not seen.wait(60):
            raise SystemExit("the baseline talker never published")
        return now() - t0
    finally:
        talker.terminate()
        talker.wait(10)
        sub.undeclare()


# -- the run ----------------------------------------------------------------------------------------------------
@contextlib.contextmanager
def running_stack(tmp: Path, robots: int, token: str) -> Iterator[Stack]:
    os.environ["PITCHSIDE_TOKEN"] = token  # the demo's launcher hands its environment to the server
    os.environ["PITCHSIDE_RECORDINGS"] = str(tmp / "recordings")
    with running_demo(tmp, "--robots", str(robots), "--compose", "none") as demo:  # each node killed alone
        match = ROUTER.search(demo.output())
        if match is None:
            raise SystemExit("the demo did not say where its Zenoh router is")
        dash = DashboardWatch(f"{demo.ws_url}?token={token}", ("joint_states", "overview"), max_hz=20)
        bus = BusWatch(match.group(1))
        procs = ProcessWatch(demo.process.pid)
        with dash:
            try:
                yield Stack(demo, bus, dash, procs, [f"robot{i}" for i in range(1, robots + 1)], token,
                            match.group(1))
            finally:
                procs.close()
                bus.close()


def victims(robots: list[str], quick: bool) -> list[str]:
    nodes = ["hcm", "telemetry"] if quick else list(NODE_TOPIC)
    return [f"{r}/{n}" for r in (robots[:1] if quick else robots) for n in nodes] + ["world", "server", "recorder"]


def fmt(x: float | None) -> str:
    """Seconds for the table and the RESULT line; inf: never (no recovery, no resumed recording)."""
    return "inf" if x is None else f"{x:.2f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, default=1)
    parser.add_argument("--quick", action="store_true", help="the HCM, telemetry, the world and the server only")
    parser.add_argument("--settle", type=float, default=None, help="seconds between recovery and the next kill")
    parser.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    args = parser.parse_args()
    if args.smoke:
        args.quick = True
    settle = args.settle if args.settle is not None else (1.5 if args.quick else 3.0)
    token = secrets.token_urlsafe(16)
    with tempfile.TemporaryDirectory() as tmp_name, running_stack(Path(tmp_name), args.robots, token) as stack:
        tmp = Path(tmp_name)
        wait_for(stack.all_flowing, timeout=120, interval=0.1, what="every robot CONTROLLABLE, data flowing")
        wait_for(lambda: all(stack.dash.first_after(r, "joint_states", "live", 0) for r in stack.robots),
                 timeout=60, interval=0.1, what="data at the dashboard")
        baseline = statistics.median(bare_node_start(stack.bus, stack.endpoint) for _ in range(3))
        stack.api("POST", "/recordings/start", {"name": "faults"})
        wait_for(lambda: stack.api("GET", "/recordings/status")["match"], timeout=60, interval=0.2,
                 what="the match recording (the simulated game leaves INITIAL)")
        time.sleep(settle)
        outcomes = []
        for victim in victims(stack.robots, args.quick):
            out = kill_and_wait(stack, victim, settle)
            outcomes.append(out)
            print(f"  killed {victim:28s} flows again after {fmt(out.flows_s)} s", flush=True)
        status = stack.api("GET", "/recordings/status")
        if status["manual"]:
            stack.api("POST", "/recordings/stop")
        if status["match"]:
            stack.demo.process.send_signal(signal.SIGTERM)  # the server closes the match file on the way out
            stack.demo.process.wait(30)
        files = sorted((tmp / "recordings").glob("*.mcap"))
        manual_files = [f for f in files if "_faults" in f.name]
        match_files = [f for f in files if f.name.startswith("match-")]
        recorded, match_recorded = recorded_payloads(manual_files), recorded_payloads(match_files)
        match_lost = match_gap = None
        recorder_match_lost = recorder_match_gap = None
        for out in outcomes:
            if out.victim == "server":
                out.lost_s, out.gap_s = server_lost(out, recorded, stack.bus)
                match_lost, match_gap = server_lost(out, match_recorded, stack.bus)
            elif out.victim == "recorder":
                out.lost_s, out.gap_s = server_lost(out, recorded, stack.bus)
                recorder_match_lost, recorder_match_gap = server_lost(out, match_recorded, stack.bus)
            elif out.flows_s is not None:
                out.lost_s = node_lost(out, recorded, stack.bus)
        demo_log = stack.demo.output()
    print(f"\n{'victim':24s} {'restarted_s':>11s} {'flows_s':>8s} {'ctrl_s':>7s} {'lost_s':>7s} {'gap_s':>6s}  "
          f"flows again means / crashes")
    for out in outcomes:
        print(f"{out.victim:24s} {fmt(out.restarted_s):>11s} {fmt(out.flows_s):>8s} {fmt(out.controllable_s):>7s} "
              f"{fmt(out.lost_s):>7s} {fmt(out.gap_s) if out.victim in ('server', 'recorder') else '':>6s}  {out.data}"
              f"{'; CRASHED: ' + ', '.join(out.crashed) if out.crashed else ''}")
    server = next(o for o in outcomes if o.victim == "server")
    recorder = next(o for o in outcomes if o.victim == "recorder")
    print(f"match recording across the recorder kill: {fmt(recorder_match_lost)} s lost before the kill, "
          f"resumed after {fmt(recorder_match_gap)} s")
    print(f"match recording across the server kill: {fmt(match_lost)} s lost before the kill, resumed after "
          f"{fmt(match_gap)} s ({len(match_files)} files: {', '.join(f.name for f in match_files)})")
    print(f"manual recording after the faults: {'running' if status['manual'] else 'NOT running'}; files: "
          f"{', '.join(f.name for f in manual_files)}")
    nodes = [o for o in outcomes if o.victim != "server"]
    node_max = max((o.flows_s if o.flows_s is not None else BACK_TIMEOUT_S) for o in nodes)
    lost_max = max(x for x in [*(o.lost_s for o in outcomes), match_lost] if x is not None)
    crashes = sum(len(o.crashed) for o in outcomes)
    restarts = demo_log.count("restarting in")
    print(f"baseline: a minimal node from spawn to its first message {baseline:.2f} s; slowest node recovery "
          f"{node_max:.2f} s = {node_max / baseline:.1f}x that; launcher restarts logged {restarts} "
          f"(kills {len(outcomes)}); machine load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print(f"RESULT faults node_recovery_max_s={node_max:.2f} server_recovery_s={fmt(server.flows_s)} "
          f"recording_lost_max_s={lost_max:.2f} crashes={crashes} server_recording_gap_s={fmt(server.gap_s)} "
          f"match_recording_gap_s={fmt(match_gap)} recorder_recovery_s={fmt(recorder.flows_s)} "
          f"recorder_recording_lost_s={fmt(recorder.lost_s)} recorder_recording_gap_s={fmt(recorder.gap_s)} "
          f"match_recording_gap_recorder_s={fmt(recorder_match_gap)} baseline_node_start_s={baseline:.2f}")


if __name__ == "__main__":
    main()
