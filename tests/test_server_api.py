"""The dashboard's REST API as a whole: every JSON endpoint described by a response model in /openapi.json, and the
HTTP status of each failure chosen by the exception's type (server.http_errors)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from robots import UnknownModel
from server.app import create_app
from server.config import ServerConfig
from server.http_errors import status_of
from server.recorder import RecorderError
from server.sources import SourceError
from server.sources.replay import BadTimelineRequest, LogNotFound, NoLogOpen, ReplayRefused, UnreadableLog
from wire.actions import ActionError
from wire.parameters import NodeSilent, ParameterError, StaleRevision
from wire.services import ServiceError

STREAMS = {"/api/robots/{robot}/params/{node}/events",  # server-sent events, not JSON
           "/api/recordings/files/{name}",  # a recording's MCAP bytes, as a download
           "/api/recordings/series/{name}"}  # a half's files as one zip
PROXIES = ("/plots/viewer/", "/robot3d/view/", "/rerun.")  # the views' own files and data, passed through


@pytest.fixture
def http(tmp_path: Path) -> Iterator[TestClient]:
    config = ServerConfig(live_source=False, telemetry_source=False, recordings_dir=tmp_path)
    with TestClient(create_app(config), base_url="http://127.0.0.1",
                    headers={"Authorization": f"Bearer {config.token}"}) as client:
        yield client


def test_every_json_endpoint_has_a_response_model(http: TestClient) -> None:
    spec = http.get("/openapi.json").json()
    described = []
    for path, methods in spec["paths"].items():
        if path in STREAMS or path.startswith(PROXIES):
            continue
        for method, op in methods.items():
            schema = op["responses"]["200"].get("content", {}).get("application/json", {}).get("schema", {})
            assert schema, f"{method.upper()} {path} says nothing of its answer"
            described.append((method, path))
    assert len(described) >= 40, described
    assert "/api/robots/{robot}/animation" not in spec["paths"]  # animations play from one endpoint


@pytest.mark.parametrize(("exc", "status"), [
    (NodeSilent("x"), 504), (ServiceError("x"), 504), (ActionError("x"), 504),
    (StaleRevision("x"), 409), (ParameterError("x"), 422),
    (LogNotFound("x"), 404), (ReplayRefused("x"), 403), (UnreadableLog("x"), 422), (BadTimelineRequest("x"), 422),
    (NoLogOpen("x"), 409), (SourceError("x"), 409), (RecorderError("x"), 409), (UnknownModel("x"), 404),
    (RuntimeError("x"), 500),
])
def test_the_status_follows_the_exception_type(exc: Exception, status: int) -> None:
    assert status_of(exc) == status


def test_replay_statuses_by_type(http: TestClient) -> None:
    """No log open: its contents are not there (404), a control of the timeline is a conflict (409)."""
    assert http.get("/api/replay/info").status_code == 404
    for control in ("play", "pause", "step"):
        reply = http.post(f"/api/replay/{control}")
        assert reply.status_code == 409 and "no log is open" in reply.json()["detail"], control
    assert http.post("/api/replay/open", json={"path": "nothing.mcap"}).status_code == 404
    (Path(http.get("/api/recordings").json()["folder"]) / "broken.mcap").write_bytes(b"not a log")
    assert http.post("/api/replay/open", json={"path": "broken.mcap"}).status_code == 422
    assert http.post("/api/replay/speed", json={"speed": 1e9}).status_code == 422
