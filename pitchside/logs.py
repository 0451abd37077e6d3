"""``pitchside logs pull``: after the game, each robot's own log of a half, checked and merged with the laptop's.

In the lab (the robots back on the team's bus), for each robot: list its log files (robot_nodes.robot_log answers
over the bus; ``--ssh ROBOT=USER@HOST:DIR`` copies them with scp instead), fetch the half's files into
``<recordings>/robot_logs/<robot>/``, open each (a file cut by a reboot reads to its last complete chunk), and merge
them with the laptop's match log of that half into ``<match log>_merged.mcap``: one timeline with every robot's
topics at full rate, clocks aligned on the messages telemetry carried, each message once. ``<match log>.pulled.json``
says which robots' logs are in it (the dashboard's recordings list shows them). ``pitchside logs merge`` does the
last step on files already here.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from wire.bus import add_bus_arguments
from wire.command_line import CommandParser

PULLED_SUFFIX = ".pulled.json"
QUERY_TIMEOUT_S = 30.0  # a busy robot answers late; nothing else waits on it


class PullError(RuntimeError):
    """A robot's logs could not be listed or fetched; the text says which and why."""


def pulled_record(laptop_log: Path) -> Path:
    return laptop_log.with_name(laptop_log.stem + PULLED_SUFFIX)


def merged_path(laptop_log: Path) -> Path:
    return laptop_log.with_name(f"{laptop_log.stem}_merged.mcap")


def half_files(names: list[str], robot: str, half: str) -> list[str]:
    """The robot's files of ``half``: named for it, and a reboot's "pregame" files started after its first one."""
    own = sorted(n for n in names if n.startswith(f"{robot}_{half}_"))
    if not own:
        return []
    first_start = own[0][len(f"{robot}_{half}_"):]
    later = sorted(n for n in names if n.startswith(f"{robot}_pregame_") and n[len(f"{robot}_pregame_"):] > first_start)
    return own + later


def fetch_over_bus(session: Any, robot: str, half: str, into: Path) -> list[Path]:
    from robot_nodes.robot_log.files import PIECE_BYTES, file_key, list_key

    listing = _ask(session, list_key(robot), None)
    names = half_files([entry["name"] for entry in json.loads(listing)], robot, half)
    sizes = {entry["name"]: int(entry["size_bytes"]) for entry in json.loads(listing)}
    into.mkdir(parents=True, exist_ok=True)
    out = []
    for name in names:
        target = into / name
        if not (target.exists() and target.stat().st_size == sizes[name]):
            with target.open("wb") as file:
                offset = 0
                while offset < sizes[name]:
                    piece = _ask(session, file_key(robot), json.dumps({"name": name, "offset": offset,
                                                                       "length": PIECE_BYTES}).encode())
                    if not piece:
                        break
                    file.write(piece)
                    offset += len(piece)
        out.append(target)
    return out


def _ask(session: Any, key: str, payload: bytes | None) -> bytes:
    """The robot's answer; asked again while nobody answers (a robot still starting its log process)."""
    deadline = time.monotonic() + QUERY_TIMEOUT_S
    while True:
        remaining = max(0.5, deadline - time.monotonic())
        for reply in session.get(key, payload=payload, timeout=remaining):
            if reply.ok is not None:
                return bytes(reply.ok.payload.to_bytes())
            raise PullError(f"{key}: {reply.err.payload.to_string()}")
        if time.monotonic() >= deadline:
            raise PullError(f"{key}: no answer within {QUERY_TIMEOUT_S:.0f} s (is the robot on the bus, its "
                            "robot_log running?)")
        time.sleep(0.5)


def fetch_over_ssh(source: str, robot: str, half: str, into: Path) -> list[Path]:
    """``source`` is USER@HOST:DIR; scp copies the robot's files of the half (and a reboot's pregame files)."""
    into.mkdir(parents=True, exist_ok=True)
    for pattern in (f"{robot}_{half}_*.mcap", f"{robot}_pregame_*.mcap"):
        done = subprocess.run(["scp", "-q", "-p", f"{source.rstrip('/')}/{pattern}", str(into)], capture_output=True)
        if done.returncode != 0 and pattern.startswith(f"{robot}_{half}"):
            raise PullError(f"scp from {source} failed: {done.stderr.decode(errors='replace').strip()}")
    return [into / n for n in half_files([p.name for p in into.glob("*.mcap")], robot, half)]


def checked(files: list[Path]) -> tuple[list[Path], list[str]]:
    """The files that open (in time order), and what was wrong with the others."""
    from schemas.logs import LogError, LogReader

    good: list[tuple[int, Path]] = []
    problems = []
    for path in files:
        try:
            with LogReader(path) as reader:
                if reader.message_count:
                    good.append((reader.start_ns, path))
        except LogError as exc:
            problems.append(f"{path.name}: {exc}")
    return [p for _, p in sorted(good)], problems


def merge_and_record(laptop_log: Path, robot_files: dict[str, list[Path]], half: str) -> dict[str, Any]:
    from schemas.logs.merge import merge_logs

    report = merge_logs(laptop_log, robot_files, merged_path(laptop_log))
    record = {"half": half, "merged": report.output.name, "messages": report.messages,
              "robots": {robot: {"files": [p.name for p in files], "messages": report.from_robot.get(robot, 0),
                                 "clock_offset_s": round(report.offsets_s.get(robot, 0.0), 6),
                                 "duplicates_dropped": report.duplicates.get(robot, 0),
                                 "clock_aligned": robot not in report.unmatched}
                         for robot, files in robot_files.items()}}
    pulled_record(laptop_log).write_text(json.dumps(record, indent=1))
    return record


def newest_match_log(folder: Path, half: str) -> Path:
    found = sorted(folder.glob(f"match-*_{half}.mcap"), key=lambda p: p.stat().st_mtime)
    if not found:
        raise SystemExit(f"pitchside logs: no match log of {half} in {folder} (give --laptop-log FILE)")
    return found[-1]


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(prog="pitchside logs", description=__doc__.splitlines()[0],
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("action", choices=["pull", "merge"],
                        help="pull: fetch each robot's half and merge; merge: merge files already here")
    parser.add_argument("--robots", required=True, help="robot ids, comma-separated")
    parser.add_argument("--half", default="half1", help="half1, half2 (default half1)")
    parser.add_argument("--recordings", type=Path, default=Path("recordings"), help="the laptop's recordings folder")
    parser.add_argument("--laptop-log", type=Path, default=None,
                        help="the laptop's match log of the half (default: the newest match-*_<half>.mcap)")
    parser.add_argument("--ssh", action="append", default=[], metavar="ROBOT=USER@HOST:DIR",
                        help="copy this robot's files with scp instead of over the bus")
    add_bus_arguments(parser)
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    robots = [r.strip() for r in args.robots.split(",") if r.strip()]
    laptop_log = args.laptop_log or newest_match_log(args.recordings, args.half)
    ssh = dict(item.split("=", 1) for item in args.ssh if "=" in item)
    robot_files: dict[str, list[Path]] = {}
    session = None
    try:
        for robot in robots:
            into = laptop_log.parent / "robot_logs" / robot
            try:
                if args.action == "merge":
                    files = [into / n for n in half_files([p.name for p in into.glob("*.mcap")], robot, args.half)]
                elif robot in ssh:
                    files = fetch_over_ssh(ssh[robot], robot, args.half, into)
                else:
                    if session is None:
                        from wire.bus import bus_from_arguments, open_session

                        session = open_session(bus_from_arguments(args))
                    files = fetch_over_bus(session, robot, args.half, into)
            except PullError as exc:
                print(f"{robot}: not pulled: {exc}", file=sys.stderr)
                continue
            good, problems = checked(files)
            for problem in problems:
                print(f"{robot}: {problem}", file=sys.stderr)
            print(f"{robot}: {len(good)} file(s) of {args.half}: {', '.join(p.name for p in good) or 'none'}")
            if good:
                robot_files[robot] = good
    finally:
        if session is not None:
            session.close()
    if not robot_files:
        raise SystemExit("pitchside logs: no robot log to merge")
    record = merge_and_record(laptop_log, robot_files, args.half)
    for robot, info in record["robots"].items():
        print(f"{robot}: {info['messages']} messages, clock offset {info['clock_offset_s']:+.3f} s"
              f"{'' if info['clock_aligned'] else ' (no shared message: not aligned)'}, "
              f"{info['duplicates_dropped']} duplicates dropped")
    print(f"merged: {laptop_log.parent / record['merged']} ({record['messages']} messages)")


if __name__ == "__main__":
    main()
