"""Shared fixtures: a Zenoh router on a free loopback port, a client session on it, Debian's chromium through
Playwright, and paths to the shared test data."""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import zenoh

from robot_nodes.runtime import BusConfig, open_router, open_session
from robot_nodes.runtime.local_bus import CHECK_FROZEN_ENV, THAWED
from tests.dashboard_server import RunningServer, dashboard_server
from tests.installs import build_wheel, fresh_venv, pip_install_extra, provide_profile
from tests.support import TESTDATA, free_port, launch_chromium
from tests.teststand import SceneStand

# a test file that imports mujoco before robot_nodes.sim must still render offscreen (that module's choice)
os.environ.setdefault("MUJOCO_GL", "egl")
# every test checks the in-process bus's rule, in this process and in the nodes it starts: a published message is
# never changed afterwards (robot_nodes/runtime/local_bus.py)
os.environ[CHECK_FROZEN_ENV] = "1"


@pytest.fixture(autouse=True)
def published_messages_stay_frozen() -> Iterator[None]:
    THAWED.clear()
    yield
    assert not THAWED, f"nodes changed messages after publishing them: {THAWED[:3]}"


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


@pytest.fixture(params=["composed", "split"])
def robot_bus(request: pytest.FixtureRequest, bus: BusConfig) -> Iterator[BusConfig | zenoh.Session]:
    """Where a test's robot nodes meet, in both layouts: one shared session ("composed", as in one process: messages
    handed over as objects) or a session each ("split", as separate processes: every message CDR through the
    router)."""
    if request.param == "split":
        yield bus
        return
    with open_session(bus) as session:
        yield session


@pytest.fixture
def testdata() -> Path:
    if not TESTDATA.exists():
        pytest.fail(f"test data not found at {TESTDATA} (tests/data/ of the repository)")
    return TESTDATA


@pytest.fixture
def client(bus: BusConfig) -> Iterator[zenoh.Session]:
    """The test's own Zenoh session on the test's router, to publish, subscribe and query like another node."""
    session = open_session(bus)
    yield session
    session.close()


@pytest.fixture
def browser() -> Iterator[Any]:
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        launched = launch_chromium(pw)
        yield launched
        launched.close()


@pytest.fixture
def stands(bus: BusConfig) -> Iterator[dict[str, SceneStand]]:
    """Two stand-in robots publishing one of everything the panels draw: r1 at (-2, 1), r2 at (2, -1.5), penalized."""
    nodes = {"r1": SceneStand("r1", bus, overrides={"x": -2.0, "y": 1.0}).start(),
             "r2": SceneStand("r2", bus, overrides={"x": 2.0, "y": -1.5, "penalized": True}).start()}
    yield nodes
    for node in nodes.values():
        node.shutdown()


@pytest.fixture
def scene(router_endpoint: str, stands: dict[str, SceneStand], tmp_path: Path) -> Iterator[RunningServer]:
    """A dashboard server that hears the stand-in robots over the test's Zenoh router."""
    with dashboard_server(["--connect", router_endpoint, "--no-telemetry"], tmp_path) as server:
        yield server


@pytest.fixture(scope="session")
def pitchside_wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The checkout's wheel, built once per test process for every install test."""
    return build_wheel(tmp_path_factory.mktemp("wheel"))


@pytest.fixture(scope="session")
def profile_venv(tmp_path_factory: pytest.TempPathFactory, pitchside_wheel: Path) -> Iterator[Any]:
    """A fresh virtualenv outside the checkout per install profile, made once per test process: the profile's
    dependencies provided offline, then pip install 'pitchside[profile]' from the wheel as a user types it.
    Call it with the profile's name; how long each took is printed (pytest -s, or in a failure's output)."""
    made: dict[str, Path] = {}

    def venv(profile: str) -> Path:
        if profile not in made:
            started = time.perf_counter()
            where = fresh_venv(tmp_path_factory.mktemp(f"install-{profile}") / "venv")
            provide_profile(where, profile)
            pip_install_extra(where, pitchside_wheel, profile)
            made[profile] = where
            print(f"{profile} profile installed in a fresh virtualenv in {time.perf_counter() - started:.1f} s")
        return made[profile]

    yield venv
