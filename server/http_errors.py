"""The HTTP status of each kind of failure, chosen by the exception's type in this one table: the routers let these
exceptions rise, and the app answers ``{"detail": <the exception's text>}`` with the status of the nearest type in
the exception's class hierarchy (Starlette looks handlers up along the MRO)."""

from __future__ import annotations

from fastapi import FastAPI
from fastapi.responses import JSONResponse
from starlette.requests import Request

from robots import UnknownModel
from schemas.logs import NotesError
from server.recorder import RecorderError
from server.sources import SourceError
from server.sources.replay import BadTimelineRequest, LogNotFound, NoLogOpen, ReplayRefused, UnreadableLog
from server.state_graph_layout import GraphTooLarge, LayoutEngineMissing, LayoutFailed
from wire.actions import ActionError
from wire.animation import AnimationError
from wire.parameters import NodeSilent, ParameterError, StaleRevision
from wire.services import ServiceError

STATUS_BY_TYPE: dict[type[Exception], int] = {
    # a robot did not answer in time
    NodeSilent: 504,
    ServiceError: 504,
    ActionError: 504,
    # a node or a file refused what was sent
    ParameterError: 422,
    AnimationError: 422,
    UnreadableLog: 422,
    NotesError: 422,
    BadTimelineRequest: 422,
    GraphTooLarge: 422,
    # what was asked for is not there
    UnknownModel: 404,
    LogNotFound: 404,
    # outside the folders this server may read
    ReplayRefused: 403,
    # right request, wrong moment: someone changed the value meanwhile, a recording runs already, no log is open
    StaleRevision: 409,
    RecorderError: 409,
    NoLogOpen: 409,
    SourceError: 409,
    # the server cannot do it: Graphviz missing, or dot failed on a graph
    LayoutEngineMissing: 503,
    LayoutFailed: 500,
}


async def _answer(_request: Request, exc: Exception) -> JSONResponse:
    return JSONResponse({"detail": str(exc)}, status_code=status_of(exc))


def status_of(exc: Exception) -> int:
    """The status of the nearest type of ``exc`` in the table (500 for one that is not in it)."""
    return next((STATUS_BY_TYPE[t] for t in type(exc).__mro__ if t in STATUS_BY_TYPE), 500)


def install_error_statuses(app: FastAPI) -> None:
    for exc_type in STATUS_BY_TYPE:
        app.add_exception_handler(exc_type, _answer)
