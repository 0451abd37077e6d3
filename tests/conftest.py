"""Shared fixtures: a Zenoh router on a free loopback port, a client session on it, Debian's chromium through
Playwright, and paths to the shared test data."""

from __future__ import annotations

import os
import socket
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import zenoh

from robot_nodes.runtime import BusConfig, open_router, open_session

REPO = Path(__file__).resolve().parents[1]
TESTDATA = REPO.parent / "shared" / "testdata"
CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update"]


def free_port(kind: int = socket.SOCK_STREAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture(scope="session", autouse=True)
def recordings_elsewhere(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """Servers started by tests (and their subprocesses) record matches into a temp folder, not recordings/."""
    folder = tmp_path_factory.mktemp("recordings")
    old = os.environ.get("PITCHSIDE_RECORDINGS")
    os.environ["PITCHSIDE_RECORDINGS"] = str(folder)
    yield folder
    if old is None:
        os.environ.pop("PITCHSIDE_RECORDINGS", None)
    else:
        os.environ["PITCHSIDE_RECORDINGS"] = old


@pytest.fixture
def router_endpoint() -> Iterator[str]:
    """A Zenoh router in this process on a random loopback port."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = open_router([endpoint])
    yield endpoint
    router.close()


@pytest.fixture
def bus(router_endpoint: str) -> BusConfig:
    """BusConfig for nodes that should meet through the test's router."""
    return BusConfig(connect=[router_endpoint])


@pytest.fixture
def testdata() -> Path:
    if not TESTDATA.exists():
        pytest.fail(f"shared test data not found at {TESTDATA}")
    return TESTDATA


@pytest.fixture
def client(bus: BusConfig) -> Iterator[zenoh.Session]:
    """The test's own Zenoh session on the test's router, to publish, subscribe and query like another node."""
    session = open_session(bus)
    yield session
    session.close()


def launch_chromium(playwright: Any) -> Any:
    """Debian's chromium, headless, through Playwright: the browser tests never download a browser."""
    if not CHROMIUM.exists():
        pytest.fail(f"{CHROMIUM} is missing: install Debian's chromium (apt-get install chromium); "
                    "the browser tests never download a browser")
    return playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)


@pytest.fixture
def browser() -> Iterator[Any]:
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        launched = launch_chromium(pw)
        yield launched
        launched.close()
