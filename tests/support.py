"""What the tests and the benchmarks share: where things are, free ports, Debian's chromium (never downloaded)."""

from __future__ import annotations

import socket
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
TESTDATA = REPO / "tests" / "data"
CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update"]


class MissingBrowser(RuntimeError):
    """Debian's chromium is not installed (./run installs it)."""


def free_port(kind: int = socket.SOCK_STREAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def launch_chromium(playwright: Any) -> Any:
    """Debian's chromium, headless, through Playwright: the browser tests never download a browser."""
    if not CHROMIUM.exists():
        raise MissingBrowser(f"{CHROMIUM} is missing: install Debian's chromium (apt-get install chromium); "
                             "the browser tests never download a browser")
    return playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
