"""The secured-bus guide works as written (issue 50, point 4): every command of docs/guides/secured-bus.md's shell
blocks, in order, on the machines the page names (the team laptop at 192.168.1.10, robot1 at 192.168.1.11: network
namespaces joined by a veth pair), each from the folder and with only the files the page gives it. The lab block
brings robot1 onto the laptop's dashboard over the secured bus; the match block brings its telemetry, sealed with
the team.key the page's first command wrote, to the match dashboard."""

from __future__ import annotations

import contextlib
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from tests import netlab
from tests.support import REPO
from tests.waiting import wait_for
from wire.telemetry.datagram import key_fingerprint, load_key

pytestmark = pytest.mark.slow

PAGE = REPO / "docs" / "guides" / "secured-bus.md"
LAPTOP, ROBOT1 = "192.168.1.10", "192.168.1.11"
TOKEN = "guide-test-token"
ONCE = ("team-keys",)  # commands that run to their end; the others run until the next block starts


def blocks() -> list[list[str]]:
    """The commands of each ```sh block of the page, comments dropped."""
    found = re.findall(r"```sh\n(.*?)```", PAGE.read_text(), re.S)
    return [[line.split("  #")[0].strip() for line in block.splitlines() if line.strip()] for block in found]


@dataclass
class Machine:
    name: str
    netns: str
    home: Path
    processes: list[subprocess.Popen[bytes]] = field(default_factory=list)

    def start(self, argv: list[str], cwd: Path, log: Path) -> subprocess.Popen[bytes]:
        with log.open("ab") as out:
            process = subprocess.Popen(["ip", "netns", "exec", self.netns, *argv], cwd=cwd, stdout=out,
                                       stderr=subprocess.STDOUT, start_new_session=True,
                                       env={**os.environ, "PYTHONUNBUFFERED": "1", "PITCHSIDE_TOKEN": TOKEN,
                                            "PYTHONPATH": str(REPO)})
        self.processes.append(process)
        return process

    def stop_all(self) -> None:
        for process in self.processes:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(process.pid, signal.SIGTERM)
        for process in self.processes:
            try:
                process.wait(20)
            except subprocess.TimeoutExpired:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(process.pid, signal.SIGKILL)
                process.wait(5)
        self.processes.clear()

    def api(self, path: str) -> Any:
        return netlab.dashboard_json(self.netns, path, TOKEN)


@pytest.fixture
def machines(tmp_path: Path) -> Iterator[dict[str, Machine]]:
    reason = netlab.skip_reason()
    if reason:
        pytest.skip(reason)
    tag = f"psg{os.getpid() % 100000}"
    made = {"laptop": Machine("laptop", f"{tag}-laptop", tmp_path / "laptop"),
            "robot1": Machine("robot1", f"{tag}-robot1", tmp_path / "robot1")}
    ends = {"laptop": (f"{tag}a", LAPTOP), "robot1": (f"{tag}b", ROBOT1)}
    try:
        for machine in made.values():
            machine.home.mkdir()
            subprocess.run(["ip", "netns", "add", machine.netns], check=True)
        subprocess.run(["ip", "link", "add", ends["laptop"][0], "type", "veth", "peer", "name", ends["robot1"][0]],
                       check=True)
        for name, machine in made.items():
            link, address = ends[name]
            for command in (["link", "set", link, "netns", machine.netns],
                            ["-n", machine.netns, "addr", "add", f"{address}/24", "dev", link],
                            ["-n", machine.netns, "link", "set", link, "up"],
                            ["-n", machine.netns, "link", "set", "lo", "up"]):
                subprocess.run(["ip", *command], check=True)
        yield made
    finally:
        for machine in made.values():
            machine.stop_all()
            subprocess.run(["ip", "netns", "del", machine.netns], check=False, capture_output=True)


def _copy(command: list[str], laptop: Machine, machines: dict[str, Machine]) -> None:
    """`scp -p FILE... HOST:` as the page writes it: the files from the laptop's folder to HOST's home, modes kept."""
    assert command[:2] == ["scp", "-p"] and command[-1].endswith(":"), command
    target = machines[command[-1][:-1]]
    for source in command[2:-1]:
        shutil.copy2(laptop.home / source, target.home / Path(source).name)


def test_the_secured_bus_guide_runs_as_written(machines: dict[str, Machine], tmp_path: Path) -> None:
    laptop, robot1 = machines["laptop"], machines["robot1"]
    team = laptop.home / "team"  # "The team laptop works in team/"
    python = [sys.executable, "-m", "pitchside.cli"]
    found = blocks()
    assert [b[0].split()[:2] for b in found] == [["pitchside", "team-keys"], ["scp", "-p"],
                                                 ["pitchside", "router"], ["pitchside", "serve"]], found
    running: list[Machine] = []
    for number, block in enumerate(found):
        for machine in running:  # a new block of long-running commands: the last one's stop
            machine.stop_all()
        running = []
        for line in block:
            argv = shlex.split(line)
            if argv[0] == "scp":
                _copy(argv, laptop, machines)
                continue
            assert argv[0] == "pitchside", line
            machine = robot1 if argv[1] == "robot" else laptop
            log = tmp_path / f"{number}-{machine.name}-{argv[1]}.log"
            if argv[1] in ONCE:
                done = machine.start([*python, *argv[1:]], machine.home, log)
                assert done.wait(120) == 0, log.read_text()
                machine.processes.remove(done)
                continue
            machine.start([*python, *argv[1:]], team if machine is laptop else machine.home, log)
            running.append(machine)
        if number == 2:  # the lab: robot1 on the laptop's dashboard, over the secured bus
            config = wait_for(lambda: laptop.api("/api/config"), 90.0, 0.5, "the lab dashboard up")
            assert config["telemetry_key"] == key_fingerprint(load_key(str(team / "team.key")))
            wait_for(lambda: "robot1" in [r["robot"] for r in laptop.api("/api/robots") or []], 120.0, 0.5,
                     "robot1 on the lab dashboard over the bus")
            # robot1 has what the page gave it and no more: its own file and the team key, private
            given = {p.name: p.stat().st_mode & 0o777 for p in robot1.home.iterdir() if p.is_file()}
            assert given == {"robot1.json5": 0o600, "team.key": 0o600}, given
        if number == 3:  # the match: robot1's telemetry, sealed with team.key, at the match dashboard
            wait_for(lambda: laptop.api("/api/config"), 90.0, 0.5, "the match dashboard up")

            def overview() -> bool:
                robots = {r["robot"]: r for r in laptop.api("/api/robots") or []}
                return "overview" in robots.get("robot1", {}).get("streams", {})

            wait_for(overview, 120.0, 0.5, "robot1's telemetry at the match dashboard")
