"""A match in simulation: how the robots play, and whether the laptop keeps real time while they do.

    python bench/match.py [--players 4 | --robots 4v4] [--half-minutes 5] [--seeds 1,2,3] [--quick] [--logs DIR]

Each seed plays one whole match as ``pitchside match --robots 4v4 --half-minutes 5 --seed S`` starts it: the MuJoCo
world with both teams and the referee, the simulated GameController running the Humanoid League flow, every
robot's nodes composed in one process each, the dashboard in match mode over one-way telemetry. ``--quick``: one
match of 2 x 2 minutes, the same figures.

From the match's own output (every node logs its state changes) and the GameController's status it counts goals (the
final score), kicks (the kick node's started kicks; also how many reached the strike, and how the others ended, from
the kick node's result lines: where a team's play loses the ball), falls (HCM into FALLING) and get-ups (HCM into
GETTING_UP), the referee's penalties (robots removed) and placements (robots not at a legal kick-off place when SET
began). For each fall it takes the time the robot lay: from its HCM's FALLEN (on the ground; the fall before it,
0.4-3 s, is not lying) until it stands again (HCM back to CONTROLLABLE or WALKING) or is penalised (the referee's
call: after 20 s lying, counted from the torso past 45 degrees; or its HCM in a penalty state, if that comes first);
the budget is 20 s. ``falling_to_up_max_s`` counts the same from the HCM's FALLING to standing or the HCM in PENALTY
(the robot hears the call with the GameController's next packet), for comparison with the figures before
2026-11-30. The world's real-time factor is its ``real_time_factor_10s`` diagnostic (simulated seconds per wall
second over the last 10 s, reported each simulated second), read on the match's Zenoh bus, minimum over the match:
whether the match kept real time. A world behind real time catches up (up to 0.25 s behind, runner.MAX_LAG), so a
slow second followed by a fast one lost nothing; ``rtf_min_1s`` is the slowest single second (the world's
``real_time_factor``), how far it fell behind for a moment. The simulated GameController runs on the world's clock:
a world that falls behind makes the match last longer. CPU is the time of every process of the match (% of one
core) over the match, and per part (world, each robot process, server) also as CPU seconds per simulated second
(``cpu_s_per_sim_s``: each of the world's ``real_time_factor`` reports is one simulated second), a figure that holds
on a loaded machine, where a slower world only spreads the same work over more wall time. Both count from the first
READY: the start-up (every process importing at once) is over by then, as the first INITIAL waits until the
GameController hears every robot. ``--logs DIR`` keeps each match's output.
Before each match bench/machine.py times a fixed Python workload (``probe_ms``): the machine's speed at the time.

The baseline in the same run: the first half's first minute of the first seed against its whole (``rtf_min_first_min``,
10 s windows): a machine that falls behind only later (memory, a growing queue) shows there.

Budgets (issue "A match in simulation"): goals_per_match >= 1, rtf_min >= 0.98, fall_to_up_max_s <= 20.
"""

from __future__ import annotations

import argparse
import contextlib
import re
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import httpx
import psutil

from bench.machine import describe, probe_ms
from robot_nodes.sim.lineup import Lineup, parse_robots
from tests.match_log import GC_URL, MatchFigures, read_output
from tests.real_time_factor import ROUTER, RealTimeFactor
from tests.running_demo import process_label, running_demo
from tests.waiting import wait_for

CLOCKS = {"lockstep": (), "sim": ("--no-lockstep",), "wall": ("--wall-clock",)}  # pitchside match's options


def play(robots: str, half_minutes: float, seed: int, out: Path, logs: Path | None, clock: str = "lockstep"
         ) -> MatchFigures:
    figures = MatchFigures(seed)
    args = ("--robots", robots, "--half-minutes", str(half_minutes), "--seed", str(seed), *CLOCKS[clock])
    with running_demo(out, *args, command="match") as match:
        gc, router = GC_URL.search(match.output()), ROUTER.search(match.output())
        assert gc and router, match.output()
        status_url = f"{gc.group(1)}/status"
        rtf = RealTimeFactor(router.group(1), first_robot(robots))
        try:
            wait_for(lambda: httpx.get(status_url, timeout=10).json()["state"] != "INITIAL", 300.0, 1.0,
                     "the first READY (the GameController waits until it hears every robot)")
            processes = match.processes()
            for p in processes:
                p.cpu_percent(None)
            figures.started = t0 = time.monotonic()
            last_report = 0.0
            while True:
                status = httpx.get(status_url, timeout=10).json()
                if status["state"] == "FINISHED" and not status["first_half"]:
                    break
                if time.monotonic() - last_report > 30:
                    last_report = time.monotonic()
                    scores = ":".join(str(t["score"]) for t in status["teams"])
                    half = "first" if status["first_half"] else "second"
                    recent = rtf.between(last_report - 30, last_report)
                    recent_10s = rtf.between(last_report - 30, last_report, rtf.values_10s)
                    print(f"  seed {seed}: {half} half, {status['state']}, {status['secs_remaining']} s left, "
                          f"{scores}; real-time factor of the last 30 s: slowest 10 s "
                          f"{min(recent_10s, default=float('nan')):.3f}, slowest 1 s "
                          f"{min(recent, default=float('nan')):.3f}", flush=True)
                time.sleep(1.0)
            figures.seconds = time.monotonic() - t0
            for p in processes:
                with contextlib.suppress(psutil.Error):
                    figures.cpu_by_process.append((process_label(p), p.cpu_percent(None)))
            figures.cpu_pct = sum(cpu for _, cpu in figures.cpu_by_process)
            figures.rtf = [(t, f) for t, f in rtf.values if t > t0]
            figures.rtf_10s = [(t, f) for t, f in rtf.values_10s if t > t0]
        finally:
            rtf.close()
        figures.goals = sum(int(t["score"]) for t in status["teams"])
        read_output(match.output(), figures)
        figures.silent_at_start = silent_at_start(match.output())
        if logs is not None:
            logs.mkdir(parents=True, exist_ok=True)
            (logs / f"match-{robots}-seed{seed}.log").write_text(match.output())
    return figures


SILENT_AT_START = re.compile(r"starting without return packets from (.*) \(waited")


def silent_at_start(output: str) -> int:
    """Robots the GameController never heard before the first kick-off (their nodes hung at start-up): a match
    with fewer robots costs less, so its CPU figures are not the lineup's."""
    found = SILENT_AT_START.search(output)
    return found.group(1).count("player") if found else 0


def cpu_s_per_sim_s(figures: MatchFigures, cpu_pct: float) -> float:
    """CPU seconds per simulated second of a part that took ``cpu_pct`` % of a core over the match (each of the
    world's real_time_factor reports is one simulated second)."""
    return cpu_pct / 100 * figures.seconds / max(1, len(figures.rtf))


def cpu_shares(figures: MatchFigures) -> str:
    """Where the CPU went, by what ran (a robot's processes summed over the robots, with the count), as % of a core
    over the match and as CPU seconds per simulated second."""
    shares: dict[str, list[float]] = {}
    for name, cpu in figures.cpu_by_process:
        kind = name.split(" ")[0] if " " in name and name.startswith("robot_nodes.") else name
        shares.setdefault(kind, []).append(cpu)
    ranked = sorted(shares.items(), key=lambda item: -sum(item[1]))
    lines = []
    for kind, cpus in ranked:
        each = f" (x{len(cpus)}, {sum(cpus) / len(cpus):.1f} % each)" if len(cpus) > 1 else ""
        if sum(cpus) >= 0.5:
            per_sim_s = cpu_s_per_sim_s(figures, sum(cpus))
            lines.append(f"    {sum(cpus):6.1f} %  {per_sim_s:5.3f} cpu-s/sim-s  {kind}{each}")
    return "\n".join(lines)


def first_robot(robots: str) -> str:
    """The home team's player 1: its cm730 node in the world reports the world's real-time factor."""
    return Lineup.of((1, 2), parse_robots(robots)).robot_ids()[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", default=None, help="robots per team, e.g. 4v4 (default 4v4)")
    parser.add_argument("--players", type=int, default=None,
                        help="robots per team, the same for both: 4 (Small Foundation, 4 v 4) or 7 (Small Advanced, "
                             "7 v 7); the same as --robots NvN")
    parser.add_argument("--half-minutes", type=float, default=5.0)
    parser.add_argument("--seeds", default="1,2,3")
    parser.add_argument("--quick", action="store_true", help="one match of 2 x 2 minutes")
    parser.add_argument("--logs", type=Path, default=None, help="keep each match's output in this folder")
    parser.add_argument("--clock", choices=list(CLOCKS), default="lockstep",
                        help="lockstep (the default): the world waits for every robot's nodes each 10 ms of "
                             "simulated time; sim: the robots follow the simulation's time but the world keeps its "
                             "own pace; wall: the robots on the wall clock")
    parser.add_argument("--smoke", action="store_true", help="a few seconds: that it runs, not what it measures")
    args = parser.parse_args()
    if args.players is not None and args.robots is not None:
        parser.error("give --players or --robots, not both")
    args.robots = f"{args.players}v{args.players}" if args.players is not None else args.robots or "4v4"
    if args.smoke:
        args.robots, args.half_minutes, args.seeds = "1v1", 0.25, "1"
    seeds = [int(s) for s in args.seeds.split(",")]
    half = args.half_minutes
    if args.quick:
        seeds, half = seeds[:1], 2.0
    matches: list[MatchFigures] = []
    probes: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in seeds:
            probes.append(probe_ms())
            print(f"match {args.robots}, 2 x {half:g} min, seed {seed}; {describe(probes[-1])}", flush=True)
            m = play(args.robots, half, seed, Path(tmp), args.logs, args.clock)
            print(f"  goals {m.goals}, kicks {m.kicks}, falls {m.falls}, get-ups {m.get_ups}, penalties "
                  f"{m.penalties}, placed at SET {m.placed}, longest time down {m.longest_down_s:.1f} s "
                  f"({len(m.still_down_s)} down at the end; from FALLING {m.longest_falling_to_up_s:.1f} s), "
                  f"rtf min {m.rtf_min:.3f} over 10 s (first minute {m.rtf_min_first_minute():.3f}), "
                  f"{m.rtf_min_1s:.3f} over 1 s ({len(m.rtf)} reports), CPU "
                  f"{m.cpu_pct:.0f} % over {m.seconds:.0f} s", flush=True)
            print(f"  kicks: {m.strikes} of {m.kicks} struck; how they ended: "
                  f"{', '.join(f'{why} {n}' for why, n in m.kick_outcomes.most_common()) or '-'}", flush=True)
            print(cpu_shares(m), flush=True)
            if m.silent_at_start:
                print(f"  WARNING: {m.silent_at_start} robots never heard by the GameController before the first "
                      "kick-off (their nodes hung at start-up): the CPU figures are not the whole lineup's", flush=True)
            matches.append(m)
    print(f"RESULT match robots={args.robots} half_minutes={half:g} matches={len(matches)} "
          f"clock={args.clock} "
          f"goals_per_match={statistics.mean(m.goals for m in matches):.2f} "
          f"kicks_per_match={statistics.mean(m.kicks for m in matches):.1f} "
          f"falls={sum(m.falls for m in matches)} get_ups={sum(m.get_ups for m in matches)} "
          f"penalties={sum(m.penalties for m in matches)} placed={sum(m.placed for m in matches)} "
          f"fall_to_up_max_s={max(m.longest_down_s for m in matches):.1f} "
          f"falling_to_up_max_s={max(m.longest_falling_to_up_s for m in matches):.1f} "
          f"rtf_min={min(m.rtf_min for m in matches):.3f} "
          f"rtf_min_1s={min(m.rtf_min_1s for m in matches):.3f} "
          f"rtf_min_first_min={matches[0].rtf_min_first_minute():.3f} "
          f"cpu_pct={statistics.mean(m.cpu_pct for m in matches):.0f} "
          f"cpu_s_per_sim_s={statistics.mean(cpu_s_per_sim_s(m, m.cpu_pct) for m in matches):.3f} "
          f"silent_at_start={sum(m.silent_at_start for m in matches)} "
          f"probe_ms={statistics.mean(probes):.0f}")


if __name__ == "__main__":
    main()
