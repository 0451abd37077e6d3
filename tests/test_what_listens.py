"""What listens, said and tested (issue 50, point 3): each command of the table in docs/concepts/security.md ("What
listens") runs as written, on a machine of its own (a network namespace with its loopback and one interface at
10.0.0.1/24, so every default port is free and the robot's telemetry goes to another machine), and the TCP ports its
processes listen on and the UDP ports they have bound, read from /proc, are exactly the table's rows for it."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import psutil
import pytest

from pitchside.team_keys import create_team
from tests import netlab
from tests.open_sockets import OpenSocket, open_sockets
from tests.support import REPO
from tests.waiting import wait_for

pytestmark = pytest.mark.slow

PAGE = REPO / "docs" / "concepts" / "security.md"
_ROW = re.compile(r"^\| `(pitchside [^`]+)` \| (TCP|UDP) ([\d.:]+):(\d+|\d+-\d+|random) \| (.+) \|$")
# a machine of its own: loopback, and an interface on the team's network (10.0.0.5 is the team PC)
_MACHINE = ("ip link set lo up && ip link add eth0 type veth peer name wire0 && ip addr add 10.0.0.1/24 dev eth0 && "
            "ip link set wire0 up && ip link set eth0 up && exec \"$@\"")


@dataclass(frozen=True)
class Row:
    protocol: str
    address: str
    ports: str  # "7447", "6665-6669" or "random"

    def matches(self, found: OpenSocket, fixed: set[int]) -> bool:
        if (found.protocol, found.address) != (self.protocol, self.address):
            return False
        if self.ports == "random":
            return found.port not in fixed
        low, _, high = self.ports.partition("-")
        return int(low) <= found.port <= int(high or low)


def table() -> dict[str, list[Row]]:
    """command -> its rows, from the page."""
    text = PAGE.read_text()
    section = text[text.index("## What listens\n"):]
    section = section[:section.index("\n## ", 1)]
    rows: dict[str, list[Row]] = {}
    for line in section.splitlines():
        found = _ROW.match(line)
        if found:
            rows.setdefault(found[1], []).append(Row(found[2], found[3], found[4]))
    return rows


def _fixed_ports(rows: list[Row]) -> set[int]:
    out: set[int] = set()
    for row in rows:
        if row.ports != "random":
            low, _, high = row.ports.partition("-")
            out.update(range(int(low), int(high or low) + 1))
    return out


def _sockets(process: subprocess.Popen[bytes]) -> set[OpenSocket]:
    try:
        tree = [psutil.Process(process.pid), *psutil.Process(process.pid).children(recursive=True)]
    except psutil.NoSuchProcess:
        return set()
    found: set[OpenSocket] = set()
    for member in tree:
        found |= open_sockets(member.pid)
    return found


@pytest.fixture(scope="module")
def team(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The folder the commands run in: a team's files as team-keys writes them (laptop.json5, team.key)."""
    reason = netlab.skip_reason()
    if reason:
        pytest.skip(reason)
    folder = tmp_path_factory.mktemp("listens") / "team"
    create_team(folder, "Bit-Bots", ["robot1"])
    return folder


@pytest.fixture(scope="module")
def running(team: Path) -> Iterator[dict[str, tuple[subprocess.Popen[bytes], Path]]]:
    """Every command of the table at once, each on its own machine: command -> (process, its log)."""
    processes = {}
    env = {k: v for k, v in os.environ.items() if not k.startswith("PITCHSIDE_")}
    try:
        for number, command in enumerate(table()):
            argv = [sys.executable, "-m", "pitchside.cli", *shlex.split(command)[1:]]
            log = team.parent / f"command{number}.log"
            with log.open("wb") as out:
                processes[command] = (subprocess.Popen(["unshare", "--net", "sh", "-c", _MACHINE, "sh", *argv],
                                                       cwd=team, stdout=out, stderr=subprocess.STDOUT,
                                                       env=dict(env, PYTHONPATH=str(REPO))), log)
        yield processes
    finally:
        for process, _ in processes.values():
            process.terminate()
        for process, _ in processes.values():
            try:
                process.wait(20)
            except subprocess.TimeoutExpired:
                process.kill()


def test_the_table_names_each_command_of_the_issue() -> None:
    assert set(table()) == {"pitchside robot",
                            "pitchside robot --match --telemetry-to 10.0.0.5 --telemetry-key team.key",
                            "pitchside serve", "pitchside serve --zenoh-config laptop.json5",
                            "pitchside serve --match --telemetry-key team.key"}


@pytest.mark.parametrize("command", sorted(table()))
def test_each_command_opens_exactly_what_the_docs_say(
        running: dict[str, tuple[subprocess.Popen[bytes], Path]], command: str) -> None:
    rows = table()[command]
    process, log = running[command]
    fixed = _fixed_ports(rows)

    def every_row_open() -> set[OpenSocket] | None:
        if process.poll() is not None:
            raise AssertionError(f"{command} exited with {process.returncode}:\n{log.read_text()[-3000:]}")
        found = _sockets(process)
        return found if all(any(row.matches(s, fixed) for s in found) for row in rows) else None

    try:
        found = wait_for(every_row_open, 90.0, 0.2, f"every socket the docs name for {command}")
    except AssertionError:
        found = _sockets(process)
        missing = [row for row in rows if not any(row.matches(s, fixed) for s in found)]
        raise AssertionError(f"{command}: nothing opens {missing}; it opens {sorted(found)}") from None
    unlisted = sorted(s for s in found if not any(row.matches(s, fixed) for row in rows))
    assert unlisted == [], f"{command} opens sockets the docs do not name: {unlisted}"
