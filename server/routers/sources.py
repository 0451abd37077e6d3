"""GET /api/sources, POST /api/sources/{name}: switch the live Zenoh and the telemetry source on and off."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Depends, HTTPException
from pydantic import BaseModel, ConfigDict

from server.deps import get_state, require_token
from server.state import ServerState
from server.zenoh_link import MATCH_MODE_REASON

router = APIRouter(prefix="/api/sources", tags=["sources"])


class SourceSwitch(BaseModel):
    enabled: bool


class SourceStatus(BaseModel):
    """A source; each kind adds its own counters (live: received, unknown_topics...; telemetry: port, messages...)."""

    model_config = ConfigDict(extra="allow")
    name: str
    running: bool
    error: str


@router.get("", response_model=list[SourceStatus])
def list_sources(state: ServerState = Depends(get_state)) -> list[dict[str, Any]]:
    return [s.status() for s in state.sources.sources.values()]


@router.post("/{name}", response_model=SourceStatus)
async def switch_source(name: str, switch: SourceSwitch, state: ServerState = Depends(require_token)
                        ) -> dict[str, Any]:
    if name not in state.sources.sources:
        raise HTTPException(404, f"no source {name!r} (have {sorted(state.sources.sources)})")
    if state.config.match_mode and name == "live" and switch.enabled:
        raise HTTPException(403, MATCH_MODE_REASON)
    source = await state.sources.switch(name, switch.enabled)  # SourceError: 409 (server.http_errors)
    return source.status()
