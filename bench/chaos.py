"""A half through chaos: a simulated 4 v 4 half while a random process is SIGKILLed every 10-20 s.

    python bench/chaos.py [--half-minutes 2] [--seed 1] [--drop 0.2]

Runs ``pitchside match`` (lockstep; the dashboard in match mode with its recorder beside it, each with a warm spare),
drops ``--drop`` of the telemetry datagrams at random (the supervisor's tap, $PITCHSIDE_TELEMETRY_DROP), and runs
the robots' own log (robot_nodes.robot_log) for one robot of each team on the match's bus. Every 10-20 s it kills
one of: a team's robot process, the world (physics, referee, GameController), the dashboard, the recorder. Per kill:
recovered (the victim's new process works: the robots' telemetry at the dashboard again for a robot process or the
world, the page for the dashboard, the recording going on for the recorder) and how long it took. Afterwards:

- laptop_recording_gap_max_s: over every kill but the recorder's, the longest silence in the match recording
  (every robot's telemetry together) around the kill, minus its usual interval, minus the silence of the robots'
  joint_states on the bus itself over the same window (in lockstep a dead robot process or world stops the whole
  simulation: that is no recording's loss); recorder_gap_max_s: the same for the recorder's kills (its budget:
  under 0.5 s plus its spare's takeover);
- robot_log_gap_max_s: the longest silence in a logged robot's robot_state outside its own process's and the
  world's down time (what the robot's log lost);
- merged_messages: the half pulled from the robots' logs over the bus and merged with the laptop's (pitchside logs);
- match_finished: the half's match recording ended (the GameController's FINISHED or half time) within the run.
"""

from __future__ import annotations

import argparse
import contextlib
import itertools
import json
import os
import random
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import httpx
import psutil

from bench.faults import lock_holders
from robot_nodes.runtime import BusConfig
from schemas.logs import LogError, LogReader, log_series
from tests.running_demo import running_demo
from tests.support import REPO
from wire import keys
from wire.bus import open_session

ROUTER = re.compile(r"Zenoh router (tcp/[0-9.]+:\d+)")
RECOVERY_TIMEOUT_S = 30.0
LOGGED_ROBOTS = ("home1", "away1")


def label_of(process: psutil.Process, holders: set[int]) -> str | None:
    """The victim class of a match process: world, team:<first robot>, server, recorder (spares: None)."""
    cmd = process.cmdline()
    if "-m" not in cmd:
        return None
    module = cmd[cmd.index("-m") + 1]
    if module.startswith("robot_nodes.cm730.sim"):
        return "world"
    if module == "robot_nodes.compose":
        return f"team:{cmd[cmd.index('--robot-id') + 1]}"
    if module in ("server", "server.recording"):
        if "--standby-lock" in cmd and process.pid not in holders:
            return None  # the warm spare
        return "server" if module == "server" else "recorder"
    return None


def victims(root: psutil.Process) -> dict[str, int]:
    holders = lock_holders()
    found = {}
    for child in root.children():
        with contextlib.suppress(psutil.Error):
            if child.status() != psutil.STATUS_ZOMBIE and (label := label_of(child, holders)) is not None:
                found[label] = child.pid
    return found


@dataclass
class Kill:
    victim: str
    at: float
    recovered_at: float | None = None
    robots: list[str] = field(default_factory=list)  # the robots of a killed team process

    @property
    def recovery_s(self) -> float | None:
        return None if self.recovered_at is None else self.recovered_at - self.at


class Dashboard:
    def __init__(self, url: str, token: str) -> None:
        self.url, self.headers = url, {"Authorization": f"Bearer {token}"}

    def get(self, path: str) -> dict | None:
        try:
            response = httpx.get(f"{self.url}/api{path}", headers=self.headers, timeout=2)
            return response.json() if response.status_code == 200 else None
        except (httpx.HTTPError, ValueError):
            return None

    def joint_states_since(self, robots: list[str] | None, since: float) -> bool:
        """Every robot (of ``robots``, else all) has sent joint_states (cm730 in the world, through the robot's own
        telemetry node) that arrived after ``since`` (wall clock)."""
        listing = self.get("/robots")
        if not isinstance(listing, list):
            return False
        now = time.time()
        arrived = {r["robot"]: now - r["streams"]["joint_states"]["age_s"] for r in listing
                   if "joint_states" in r.get("streams", {}) and not r.get("replayed")}
        wanted = robots or list(arrived)
        return bool(wanted) and all(r in arrived and arrived[r] > since for r in wanted)


def recovered(kill: Kill, dash: Dashboard, before: dict[str, int], root: psutil.Process) -> bool:
    now_pids = victims(root)
    new_pid = now_pids.get(kill.victim)
    if new_pid in (None, before.get(kill.victim)):
        return False
    if kill.victim == "server":
        return dash.get("/config") is not None
    if kill.victim == "recorder":
        status = dash.get("/recordings/status") or {}
        process = status.get("process") or {}
        return bool(process.get("up") and process.get("pid") == now_pids["recorder"])
    try:
        started = psutil.Process(new_pid).create_time()
    except psutil.Error:
        return False
    return dash.joint_states_since(kill.robots or None, max(started, kill.at))


def silence(times: list[float], start: float, end: float) -> float:
    """The longest gap between recorded times inside [start, end], minus the usual interval there."""
    inside = sorted(t for t in times if start <= t <= end)
    if len(inside) < 3:
        return end - start
    gaps = [b - a for a, b in itertools.pairwise([start, *inside, end])]
    return max(0.0, max(gaps) - statistics.median(gaps))


def recorded_times(files: list[Path], topics: list[str] | None = None,
                   robots: list[str] | None = None) -> dict[str, list[float]]:
    out: dict[str, list[float]] = defaultdict(list)
    for path in files:
        try:
            with LogReader(path) as log:
                for m in log.messages(topics=topics, robots=robots, decode=False):
                    out[m.robot_id].append(m.log_time_ns / 1e9)
        except LogError as exc:
            print(f"  {path.name}: {exc}")
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--half-minutes", type=float, default=2.0)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--drop", type=float, default=0.2, help="share of telemetry datagrams dropped")
    parser.add_argument("--every", type=float, nargs=2, default=(10.0, 20.0), metavar=("MIN_S", "MAX_S"))
    parser.add_argument("--players", type=int, default=4, help="robots per team (the issue's half: 4)")
    parser.add_argument("--smoke", action="store_true", help="a short 1 v 1 half with a kill or two: that it runs")
    args = parser.parse_args()
    if args.smoke:
        args.players, args.half_minutes, args.every = 1, 0.25, (5.0, 8.0)
    rng = random.Random(args.seed)
    token = "chaos-" + str(rng.randrange(10**9))
    kills: list[Kill] = []
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        recordings, robot_logs = tmp / "recordings", tmp / "robot_logs"
        os.environ.update({"PITCHSIDE_TOKEN": token, "PITCHSIDE_RECORDINGS": str(recordings),
                           "PITCHSIDE_TELEMETRY_DROP": str(args.drop)})
        match_args = ("--players", str(args.players), "--half-minutes", str(args.half_minutes),
                      "--seed", str(args.seed),
                      "--initial-seconds", "2", "--ready-seconds", "15", "--set-seconds", "2")
        with running_demo(tmp, *match_args, command="match", up_timeout_s=600) as match:
            endpoint = ROUTER.search(match.output())
            assert endpoint is not None, "the match did not say where its Zenoh router is"
            loggers = [subprocess.Popen([sys.executable, "-m", "robot_nodes.robot_log", "--robot-id", robot,
                                         "--connect", endpoint.group(1), "--folder", str(robot_logs / robot)],
                                        cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                       for robot in LOGGED_ROBOTS]
            dash = Dashboard(match.url, token)
            # the robots' joint_states on the match's bus (the bench listens there, not the laptop)
            bus_times: list[float] = []
            bus = open_session(BusConfig(connect=[endpoint.group(1)]))
            bus_sub = bus.declare_subscriber(keys.topic_key("*", "joint_states"),
                                             lambda _sample: bus_times.append(time.time()))
            root = psutil.Process(match.process.pid)
            deadline = time.monotonic() + 600
            while not (dash.get("/recordings/status") or {}).get("match") and time.monotonic() < deadline:
                time.sleep(0.5)
            started = time.time()
            print(f"half1 recording; killing every {args.every[0]:.0f}-{args.every[1]:.0f} s", flush=True)
            half_end = started + args.half_minutes * 60 * 3 + 120  # lockstep on a busy machine: slower than real time
            finished = False
            while time.time() < half_end:
                wait_until = time.time() + rng.uniform(*args.every)
                while time.time() < wait_until and not finished:
                    status = dash.get("/recordings/status") or {}
                    finished = any(r.get("reason") == "match" for r in status.get("recent", []))
                    time.sleep(0.5)
                if finished:
                    break
                before = victims(root)
                victim = rng.choice(sorted(before))
                kill = Kill(victim, time.time())
                if victim.startswith("team:"):
                    members = psutil.Process(before[victim]).cmdline()
                    kill.robots = [members[i + 1] for i, a in enumerate(members) if a == "--robot-id"]
                os.kill(before[victim], signal.SIGKILL)
                kills.append(kill)
                limit = time.time() + RECOVERY_TIMEOUT_S
                while time.time() < limit:
                    if recovered(kill, dash, before, root):
                        kill.recovered_at = time.time()
                        break
                    time.sleep(0.05)
                print(f"  killed {victim:14s} recovered after "
                      f"{'never' if kill.recovery_s is None else f'{kill.recovery_s:.2f} s'}", flush=True)
            bus_sub.undeclare()
            bus.close()
            # the robots back in the lab: their logs stop recording and serve the files (as after a reboot)
            for logger in loggers:
                logger.terminate()
                logger.wait(10)
            loggers = [subprocess.Popen([sys.executable, "-m", "robot_nodes.robot_log", "--robot-id", robot,
                                         "--connect", endpoint.group(1), "--folder", str(robot_logs / robot),
                                         "--no-record"], cwd=REPO, stdout=subprocess.DEVNULL,
                                        stderr=subprocess.DEVNULL) for robot in LOGGED_ROBOTS]
            robots = ",".join(LOGGED_ROBOTS)
            match_logs = sorted(recordings.glob("match-*_half1.mcap"))
            merged_messages = 0
            if match_logs:
                pull = subprocess.run([sys.executable, "-m", "pitchside.cli", "logs", "pull", "--robots", robots,
                                       "--half", "half1", "--laptop-log", str(match_logs[-1]), "--connect",
                                       endpoint.group(1)], cwd=REPO, capture_output=True, text=True)
                print(pull.stdout + pull.stderr)
                record = match_logs[-1].with_name(match_logs[-1].stem + ".pulled.json")
                if record.exists():
                    merged_messages = json.loads(record.read_text())["messages"]
            for logger in loggers:
                logger.terminate()
                logger.wait(10)
        laptop = recorded_times(log_series(match_logs[-1]) if match_logs else [])
        laptop_all = sorted(t for times in laptop.values() for t in times)
        robot_times = {r: recorded_times(sorted((robot_logs / r).glob("*.mcap")), ["robot_state"], [r]).get(r, [])
                       for r in LOGGED_ROBOTS}
    def window(k: Kill) -> tuple[float, float]:
        return k.at - 2.0, k.at + (k.recovery_s or RECOVERY_TIMEOUT_S) + 2.0

    gaps = {id(k): max(0.0, silence(laptop_all, *window(k)) - silence(bus_times, *window(k))) for k in kills}
    laptop_gap = max((gaps[id(k)] for k in kills if k.victim != "recorder"), default=0.0)
    recorder_gap = max((gaps[id(k)] for k in kills if k.victim == "recorder"), default=0.0)
    robot_gap = 0.0
    for robot, times in robot_times.items():
        down = [(k.at, k.at + (k.recovery_s or RECOVERY_TIMEOUT_S)) for k in kills
                if k.victim == "world" or robot in k.robots]
        times = sorted(times)
        for a, b in itertools.pairwise(times):
            if not any(s - 1.0 <= b and a <= e + 1.0 for s, e in down):
                robot_gap = max(robot_gap, b - a)
    recovered_count = sum(k.recovered_at is not None for k in kills)
    recovery_max = max((k.recovery_s or RECOVERY_TIMEOUT_S for k in kills), default=0.0)
    print(f"\n{'victim':14s} {'recovery_s':>10s} {'laptop_gap_s':>12s}")
    for k in kills:
        print(f"{k.victim:14s} {'never' if k.recovery_s is None else f'{k.recovery_s:.2f}':>10s} {gaps[id(k)]:12.2f}")
    print(f"machine load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores (shared with other work)")
    print(f"RESULT chaos kills={len(kills)} recovered={recovered_count} recovery_max_s={recovery_max:.2f} "
          f"laptop_recording_gap_max_s={laptop_gap:.2f} recorder_gap_max_s={recorder_gap:.2f} "
          f"robot_log_gap_max_s={robot_gap:.2f} merged_messages={merged_messages} match_finished={int(finished)}")


if __name__ == "__main__":
    main()
