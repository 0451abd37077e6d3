"""`pitchside doctor` on the team laptop: the install profiles, the dashboard's ports, and the browsers the tests
drive when the test tools are installed. The checks shared with the robot (router, disk) stay in pitchside.doctor;
like it, this module needs only the core install, so the doctor runs before anything else is installed."""

from __future__ import annotations

import importlib.util
import shutil
import socket
from dataclasses import dataclass
from pathlib import Path

from pitchside import __version__, profiles
from pitchside.checks import Check, Status

DASHBOARD_PORT = 8080  # pitchside serve --port
FOXGLOVE_PORT = 8765  # pitchside serve --foxglove-port (it takes a free one if taken)
TELEMETRY_PORT = 5800  # pitchside serve --telemetry-port (UDP)
# the browsers the browser tests drive (Debian's, never downloaded): tests/support.py and tests/firefox_bidi.py
TEST_BROWSERS = {"chromium": Path("/usr/bin/chromium"), "firefox-esr": Path("/usr/bin/firefox-esr")}


def profile(needed: str, role: str) -> Check:
    """The profiles installed here, and whether the one this machine's role needs is among them."""
    name = "profile"
    have = profiles.installed()
    detail = f"pitchside {__version__}, installed profiles: {', '.join(have) or 'none'}"
    absent = profiles.missing(needed)
    if absent:
        return Check(name, Status.FAIL, f"{detail}; the {role} needs {needed} ({', '.join(absent[:4])} missing)",
                     profiles.install_command(needed))
    return Check(name, Status.OK, detail)


@dataclass(frozen=True)
class Port:
    number: int
    udp: bool
    what: str  # whose port, in the user's words
    option: str  # the option of pitchside serve that moves it
    required: bool = True  # a taken port the server cannot work around


def _taken(port: Port, host: str) -> str | None:
    """Why the port cannot be bound, or None when it is free."""
    kind = socket.SOCK_DGRAM if port.udp else socket.SOCK_STREAM
    with socket.socket(socket.AF_INET, kind) as sock:
        if not port.udp:  # as the server binds: a socket of a stopped server in TIME_WAIT does not count
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind((host, port.number))
        except OSError as exc:
            return exc.strerror or str(exc)
    return None


def ports_free(ports: list[Port], host: str = "127.0.0.1") -> Check:
    name = "ports free"
    taken = [(p, why) for p in ports if (why := _taken(p, "" if p.udp else host))]
    listed = ", ".join(f"{'UDP' if p.udp else 'TCP'} {p.number} ({p.what})" for p in ports)
    blocking = [(p, why) for p, why in taken if p.required]
    notes = "; ".join(f"{p.what} port {p.number} taken ({why}): the server takes a free one" for p, why in taken
                      if not p.required)
    if blocking:
        first = blocking[0][0]
        proto = "u" if first.udp else "t"
        detail = "; ".join(f"{'UDP' if p.udp else 'TCP'} {p.number} ({p.what}) taken: {why}" for p, why in blocking)
        return Check(name, Status.FAIL, detail,
                     f"another program holds it (ss -{proto}lpn 'sport = :{first.number}' names it; a pitchside serve "
                     f"already running?): stop it, or give pitchside serve {first.option} PORT")
    return Check(name, Status.OK, f"{listed} free" + (f"; {notes}" if notes else ""))


def dashboard_ports(port: int, foxglove_port: int, telemetry_port: int) -> list[Port]:
    return [Port(port, False, "dashboard", "--port"),
            Port(telemetry_port, True, "telemetry", "--telemetry-port"),
            Port(foxglove_port, False, "Foxglove", "--foxglove-port", required=False)]


def test_tools_installed() -> bool:
    return all(importlib.util.find_spec(m) is not None for m in ("pytest", "playwright"))


def test_browsers(tools: bool | None = None, browsers: dict[str, Path] | None = None) -> Check:
    """Only a checkout that runs the tests needs the browsers; without the test tools this is skipped."""
    name = "test browsers"
    if not (test_tools_installed() if tools is None else tools):
        return Check(name, Status.SKIP, "the test tools are not installed (only ./run test needs the browsers)")
    browsers = TEST_BROWSERS if browsers is None else browsers
    absent = [b for b, path in browsers.items() if not path.exists() and shutil.which(b) is None]
    if absent:
        return Check(name, Status.FAIL, f"{', '.join(absent)} not found (the browser tests use Debian's, never a "
                     "downloaded one)", f"sudo apt-get install {' '.join(absent)} (./run setup does it)")
    return Check(name, Status.OK, ", ".join(f"{b} {p}" for b, p in browsers.items()))
