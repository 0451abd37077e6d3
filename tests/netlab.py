"""Machines on a test network: Linux network namespaces joined through an emulated radio (tests.netshaper).

Each machine (laptop, robot1, ...) is a namespace with its own loopback and one interface ``eth0`` at
10.88.0.<n>/24, as separate computers have; the other end of its veth pair sits in the ``air`` namespace,
where the netshaper hub passes frames between machines with the delay, jitter, loss and cuts a test asks for.
Machines speak IPv4 only: IPv6 is off in every namespace, so a kernel's own chatter (router solicitations, MLD,
duplicate address detection) never counts as a frame one machine sent another. ``Machine.connect`` opens a TCP
connection from inside a machine (a browser on the laptop) for code that runs outside the namespaces.
Needs root (CI runs as root) and ``ip``/``ethtool``; ``skip_reason()`` says why a test cannot run here.
"""

from __future__ import annotations

import contextlib
import ctypes
import itertools
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

T = TypeVar("T")
REPO = Path(__file__).resolve().parents[1]
SUBNET = "10.88.0"
CLONE_NEWNET = 0x40000000
_ids = itertools.count(os.getpid() % 1000 * 10)


def skip_reason() -> str | None:
    """Why machines in namespaces cannot be made here, or None."""
    if os.geteuid() != 0:
        return "network namespaces need root (CI runs as root)"
    for tool in ("ip", "ethtool"):
        if shutil.which(tool) is None:
            return f"{tool} is missing (./run installs iproute2 and ethtool)"
    return None


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, text=True)


def _ipv4_only(netns: str) -> None:
    """IPv6 off in a namespace before its links come up (no file for it when the kernel has no IPv6: fine)."""
    subprocess.run(["ip", "netns", "exec", netns, "sh", "-c", "for c in all default; do "
                    "echo 1 > /proc/sys/net/ipv6/conf/$c/disable_ipv6; done"], capture_output=True, check=False)


def in_namespace(netns: str, work: Callable[[], T]) -> T:
    """work() on a thread that has joined the namespace: sockets it makes belong there and stay usable anywhere."""
    result: list[T] = []
    failure: list[BaseException] = []

    def run() -> None:
        libc = ctypes.CDLL(None, use_errno=True)
        try:
            with open(f"/run/netns/{netns}") as handle:
                if libc.setns(handle.fileno(), CLONE_NEWNET) != 0:  # this thread only; it ends right after
                    errno = ctypes.get_errno()
                    raise OSError(errno, f"setns into {netns}: {os.strerror(errno)}")
            result.append(work())
        except BaseException as exc:  # handed to the caller's thread
            failure.append(exc)

    thread = threading.Thread(target=run, name=f"in-{netns}")
    thread.start()
    thread.join()
    if failure:
        raise failure[0]
    return result[0]


def dashboard_json(netns: str, path: str, token: str, port: int = 8080) -> Any:
    """GET a dashboard's JSON answer from inside a machine (its /api on that machine's loopback), or None while it
    is not up or refuses."""
    import httpx

    def get() -> Any:
        try:
            reply = httpx.get(f"http://127.0.0.1:{port}{path}", headers={"Authorization": f"Bearer {token}"},
                              timeout=2.0)
        except httpx.HTTPError:
            return None
        return reply.json() if reply.status_code == 200 else None
    return in_namespace(netns, get)


@dataclass
class Machine:
    """One computer of the test network: a namespace with eth0 at ``address``."""

    name: str
    netns: str
    address: str
    mac: str = ""
    processes: list[subprocess.Popen[bytes]] = field(default_factory=list)

    def command(self, argv: list[str]) -> list[str]:
        return ["ip", "netns", "exec", self.netns, *argv]

    def run(self, argv: list[str], **kwargs: Any) -> subprocess.CompletedProcess[str]:
        return subprocess.run(self.command(argv), capture_output=True, text=True, **kwargs)

    def start(self, argv: list[str], log: Path, env: dict[str, str] | None = None) -> subprocess.Popen[bytes]:
        """A process on this machine (its output in ``log``), stopped with the network."""
        with log.open("ab") as out:
            process = subprocess.Popen(self.command(argv), stdout=out, stderr=subprocess.STDOUT, cwd=REPO,
                                       env={**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})},
                                       start_new_session=True)
        self.processes.append(process)
        return process

    def connect(self, address: tuple[str, int], timeout: float = 5.0) -> socket.socket:
        """A TCP connection made from this machine (e.g. to a server on its loopback); OSError if refused."""
        return in_namespace(self.netns, lambda: socket.create_connection(address, timeout))

    def python(self, module_args: list[str], log: Path, env: dict[str, str] | None = None) -> subprocess.Popen[bytes]:
        return self.start([sys.executable, "-m", *module_args], log, env)

    def stop_all(self) -> None:
        for process in reversed(self.processes):
            if process.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(process.pid, signal.SIGTERM)
        for process in self.processes:
            try:
                process.wait(10)
            except subprocess.TimeoutExpired:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(process.pid, signal.SIGKILL)
                process.wait(5)
        self.processes.clear()


class Network:
    """Machines and the air between them; ``shape()`` changes a machine's link while everything runs."""

    def __init__(self, names: list[str], log_dir: Path) -> None:
        self.tag = f"ps{next(_ids)}"
        self.log_dir = log_dir
        self.air = f"{self.tag}-air"
        self.machines: dict[str, Machine] = {}
        self._control = Path(tempfile.mkdtemp(prefix="netshaper-")) / "control.sock"
        self._reply = self._control.with_name("reply.sock")
        self._shaper: subprocess.Popen[bytes] | None = None
        try:
            self._build(names)
        except BaseException:
            self.close()
            raise

    def _build(self, names: list[str]) -> None:
        _ip("netns", "add", self.air)
        _ipv4_only(self.air)
        _ip("-n", self.air, "link", "set", "lo", "up")
        ports = []
        for n, name in enumerate(names, start=1):
            netns = f"{self.tag}-{name}"
            _ip("netns", "add", netns)
            _ipv4_only(netns)
            port = f"l{n}"
            _ip("link", "add", f"{self.tag}e{n}", "type", "veth", "peer", "name", f"{self.tag}p{n}")
            _ip("link", "set", f"{self.tag}e{n}", "netns", netns, "name", "eth0")
            _ip("link", "set", f"{self.tag}p{n}", "netns", self.air, "name", port)
            machine = Machine(name, netns, f"{SUBNET}.{n}")
            _ip("-n", netns, "addr", "add", f"{machine.address}/24", "dev", "eth0")
            for dev, ns in (("eth0", netns), (port, self.air)):
                _ip("-n", ns, "link", "set", dev, "up")
                # whole frames of at most the MTU: the hub passes frames, it does not segment
                subprocess.run(["ip", "netns", "exec", ns, "ethtool", "-K", dev, "tso", "off", "gso", "off",
                                "gro", "off", "tx", "off", "rx", "off"], capture_output=True, check=False)
            _ip("-n", netns, "link", "set", "lo", "up")
            machine.mac = machine.run(["cat", "/sys/class/net/eth0/address"]).stdout.strip()
            self.machines[name] = machine
            ports.append(port)
        self._ports = dict(zip(names, ports, strict=True))
        log = (self.log_dir / "netshaper.log").open("ab")
        self._shaper = subprocess.Popen(["ip", "netns", "exec", self.air, sys.executable, "-m", "tests.netshaper",
                                         "--control", str(self._control), *ports], cwd=REPO, stdout=log,
                                        stderr=subprocess.STDOUT)
        self._client = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self._client.bind(str(self._reply))
        self._client.settimeout(10)
        deadline = 100
        while not self._control.exists() and deadline:
            if self._shaper.poll() is not None:
                raise RuntimeError(f"netshaper exited: {(self.log_dir / 'netshaper.log').read_text()}")
            deadline -= 1
            subprocess.run(["sleep", "0.05"], check=True)
        self.shape("*")

    def __getitem__(self, name: str) -> Machine:
        return self.machines[name]

    def shape(self, machine: str, **link: Any) -> dict[str, Any]:
        """Sets a machine's link ("*": all): delay_ms, jitter_ms, loss (0..1), cut; returns every link's counters."""
        port = "*" if machine == "*" else self._ports[machine]
        self._client.sendto(json.dumps({"port": port, **link}).encode(), str(self._control))
        answer: dict[str, Any] = json.loads(self._client.recv(1 << 20))
        if "error" in answer:
            raise ValueError(answer["error"])
        return {name: answer[port] for name, port in self._ports.items()}

    def frames_between(self, source: str, destination: str, arp: bool = False) -> int:
        """Frames ``source`` addressed to ``destination`` (unicast, by MAC) that the air delivered; ARP only if
        asked. Broadcast and multicast frames (IPv6 neighbour discovery) are addressed to no machine."""
        counters = self.shape(destination)[destination]["frames_from"]
        pair = f"{self.machines[source].mac}>{self.machines[destination].mac}/"
        return sum(int(n) for key, n in counters.items()
                   if key.startswith(pair) and (arp or not key.endswith("/0806")))

    def close(self) -> None:
        for machine in self.machines.values():
            machine.stop_all()
        if self._shaper is not None:
            self._shaper.kill()
            self._shaper.wait(5)
        with contextlib.suppress(AttributeError, OSError):
            self._client.close()
        for machine in self.machines.values():
            subprocess.run(["ip", "netns", "del", machine.netns], capture_output=True, check=False)
        subprocess.run(["ip", "netns", "del", self.air], capture_output=True, check=False)
        shutil.rmtree(self._control.parent, ignore_errors=True)


@contextlib.contextmanager
def network(names: list[str], log_dir: Path) -> Iterator[Network]:
    net = Network(names, log_dir)
    try:
        yield net
    finally:
        net.close()
