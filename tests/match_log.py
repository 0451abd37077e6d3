"""What a match's own output says happened: every node logs its state changes (``[pitchside.<robot>.<node>]``)
and the referee its calls. Read by tests/test_match.py and bench/match.py."""

from __future__ import annotations

import re
from collections import Counter
from dataclasses import dataclass, field
from datetime import datetime

GC_URL = re.compile(r"GameController (http://127\.0\.0\.1:\d+)/status")  # where a match says its GC's API is
STAMP = re.compile(r"^(\d{4}-\d\d-\d\d \d\d:\d\d:\d\d,\d{3}) ")
LINE = re.compile(r"^(\d{4}-\d\d-\d\d \d\d:\d\d:\d\d,\d{3}) \w+ \[pitchside\.(\w+)\.(\w+)\] (.*)$")
HCM_CHANGE = re.compile(r"^(\w+) -> (\w+) ")
SIM_TIME = re.compile(r" at sim (\d+(?:\.\d+)?) s$")  # an HCM on simulated time says when, in it
REFEREE_TIME = re.compile(r"referee at (\d+(?:\.\d+)?) s:")
REFEREE_PENALTY = re.compile(r"referee at [\d.]+ s: penalty team (\d+) player (\d+)")
LINEUP_TEAM = re.compile(r"team (\d+) \(([\w, ]+)\)")  # the world's "match 4v4: team 1 (home1, ...) against ..."
KICK_END = re.compile(r"^kick (succeeded|aborted|canceled): ([^:(]*)")  # the kick node's result and why
UP_AGAIN = {"CONTROLLABLE", "WALKING"}
PENALISED = {"PENALTY_ANIMATION_IN", "PENALTY"}


@dataclass
class MatchFigures:
    """One match."""

    seed: int
    goals: int = 0
    kicks: int = 0
    strikes: int = 0  # kicks that got as far as the kicking motion
    kick_outcomes: Counter[str] = field(default_factory=Counter)  # "aborted: the ball did not go" -> how often
    falls: int = 0
    get_ups: int = 0
    penalties: int = 0
    placed: int = 0  # robots the referee had to place at SET (not at a legal kick-off position in time)
    # per fall: from lying (the HCM in FALLEN; FALLING until then) until standing again (the HCM) or penalised (the
    # referee's call, or the HCM in a penalty state if it comes first)
    fall_to_up_s: list[float] = field(default_factory=list)
    still_down_s: list[float] = field(default_factory=list)  # per robot still down when the output ends: how long
    # per fall, counted from the HCM's FALLING (the fall itself, 0.4-3 s, included) until standing again or the HCM
    # in a penalty state (the robot hears the referee's call with the GameController's next packet)
    falling_to_up_s: list[float] = field(default_factory=list)
    rtf: list[tuple[float, float]] = field(default_factory=list)  # (time.monotonic(), factor over 1 s)
    rtf_10s: list[tuple[float, float]] = field(default_factory=list)  # (time.monotonic(), factor over 10 s)
    cpu_pct: float = 0.0
    cpu_by_process: list[tuple[str, float]] = field(default_factory=list)  # (what it runs, % of one core)
    seconds: float = 0.0
    started: float = 0.0
    silent_at_start: int = 0  # robots the GameController never heard before the first kick-off

    @property
    def longest_down_s(self) -> float:
        """The longest time a robot lay (fell until it stood again or was penalised, or until the output ended)."""
        return max(self.fall_to_up_s + self.still_down_s, default=0.0)

    @property
    def longest_falling_to_up_s(self) -> float:
        return max(self.falling_to_up_s + self.still_down_s, default=0.0)

    @property
    def rtf_min(self) -> float:
        """The slowest 10 s of the match (windows wholly after ``started``): whether the match kept real time. The
        world catches up a short lag (runner.MAX_LAG), so a slow second followed by a fast one lost nothing."""
        return min((f for t, f in self.rtf_10s if t >= self.started + 10.0), default=0.0)

    @property
    def rtf_min_1s(self) -> float:
        """The slowest second: how far the world fell behind for a moment."""
        return min((f for _, f in self.rtf), default=0.0)

    def rtf_min_first_minute(self) -> float:
        return min((f for t, f in self.rtf_10s if self.started + 10.0 <= t < self.started + 60.0), default=0.0)


def read_output(text: str, figures: MatchFigures) -> None:
    """Counts from the match's log lines: the kick node's kicks, the HCM's falls and get-ups, the referee's calls.
    Times down are in the simulation's seconds when the HCMs follow it (their lines say "at sim T s"), else in the
    wall clock's of the lines' stamps."""
    down_since: dict[str, float] = {}  # robot -> since when it lies (FALLEN; FALLING until it got there)
    lying: set[str] = set()  # robots whose down_since is their FALLEN
    falling_since: dict[str, float] = {}  # robot -> its HCM's FALLING
    robot_of: dict[tuple[int, int], str] = {}  # (team, player) -> robot, from the world's lineup line
    t = 0.0
    lines = text.splitlines()
    simulated = any(SIM_TIME.search(line) for line in lines)
    for line in lines:
        if "match " in line and " against team " in line:
            for team, robots in LINEUP_TEAM.findall(line):
                robot_of.update({(int(team), player): robot.strip()
                                 for player, robot in enumerate(robots.split(","), start=1)})
        if "referee at" in line and ": removed team" in line:
            figures.penalties += 1
        if "referee at" in line and ": placed team" in line:
            figures.placed += 1
        if simulated and (called := REFEREE_TIME.search(line)):
            t = max(t, float(called.group(1)))  # the simulation's time goes on while a robot lies
        elif not simulated and (stamped := STAMP.match(line)):
            t = datetime.strptime(stamped.group(1), "%Y-%m-%d %H:%M:%S,%f").timestamp()
        if (penalty := REFEREE_PENALTY.search(line)) and (
                robot := robot_of.get((int(penalty.group(1)), int(penalty.group(2))))) in down_since:
            figures.fall_to_up_s.append(t - down_since.pop(robot))  # penalised: the GameController has it
            lying.discard(robot)
        found = LINE.match(line)
        if found is None:
            continue
        _, robot, node, message = found.groups()
        if simulated and (at := SIM_TIME.search(message)):
            t = max(t, float(at.group(1)))
        if node == "kick" and message.startswith("kick with the"):
            figures.kicks += 1
        elif node == "kick" and message.startswith("strike with the"):
            figures.strikes += 1
        elif node == "kick" and (end := KICK_END.match(message)):
            why = re.sub(r"\d+(\.\d+)?", "N", end.group(2).strip())
            figures.kick_outcomes[f"{end.group(1)}: {why}"] += 1
        elif node == "hcm" and (change := HCM_CHANGE.match(message)):
            after = change.group(2)
            if after == "FALLING":
                figures.falls += 1
                falling_since.setdefault(robot, t)
                down_since.setdefault(robot, t)
            elif after == "FALLEN" and robot in down_since and robot not in lying:
                down_since[robot] = t  # on the ground now: the fall itself is over
                lying.add(robot)
            elif after == "GETTING_UP":
                figures.get_ups += 1
            elif after in UP_AGAIN or after in PENALISED:
                if robot in down_since:
                    figures.fall_to_up_s.append(t - down_since.pop(robot))
                lying.discard(robot)
                if robot in falling_since:
                    figures.falling_to_up_s.append(t - falling_since.pop(robot))
    figures.still_down_s = [t - since for since in down_since.values()]

