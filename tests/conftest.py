"""Shared fixtures: a Zenoh router on a free loopback port, and paths to the shared test data."""

from __future__ import annotations

import os
import socket
from collections.abc import Iterator
from pathlib import Path

import pytest

from robot_nodes.runtime import BusConfig, open_router

REPO = Path(__file__).resolve().parents[1]
TESTDATA = REPO.parent / "shared" / "testdata"


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
