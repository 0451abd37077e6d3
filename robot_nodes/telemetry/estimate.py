"""Dry run: the bytes/s a telemetry configuration would send, per stream, before it goes on a match network."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

import schemas
from robot_nodes.telemetry.budget import SHARES
from robot_nodes.telemetry.sender import IMAGE_TOPIC, TelemetryParams, parse_topics
from schemas.codec import Message, full_name, schema_hash
from schemas.messages import BallInImage
from schemas.std import DiagnosticStatus, Header, JointTrajectoryPoint, KeyValue, Temperature
from schemas.topics import Priority, topic
from wire.telemetry.datagram import HEADER_SIZE, OVERVIEW_SIZE, TAG_SIZE, StreamInfo, encode_stream_tables

OVERHEAD = HEADER_SIZE + TAG_SIZE
JOINTS = 20
PASS_THROUGH_IMAGE_BYTES = 60_000  # a 640x480 camera JPEG at quality ~85
IMAGE_BYTES_PER_PIXEL = 0.12  # downscaled JPEG at quality ~60, textured field scene


def _typical(name: str) -> Message:
    """A message of the sizes a kid-size robot sends (20 joints, a few candidates)."""
    typename = topic(name).type
    names = [f"joint_{i:02d}" for i in range(JOINTS)]
    if name in ("joint_states",):
        return schemas.make(typename, name=names, position=np.zeros(JOINTS), velocity=np.zeros(JOINTS),
                            effort=np.zeros(JOINTS))
    if typename.endswith("JointTrajectory"):
        point = schemas.make(JointTrajectoryPoint, positions=np.zeros(JOINTS))
        return schemas.make(typename, joint_names=names, points=[point])
    if name == "servo_data":
        temp = schemas.make(Temperature, header=schemas.make(Header, frame_id="joint_00"))
        return schemas.make(typename, temperature=[temp] * JOINTS, voltage=np.zeros(1))
    if name == "diagnostics":
        kv = schemas.make(KeyValue, key="rate_hz/some_timer", value="100.0")
        status = schemas.make(DiagnosticStatus, name="robot1/node", message="OK", values=[kv] * 8)
        return schemas.make(typename, status=[status])
    if name == "hcm_graph":
        states = [f"STATE_{i}" for i in range(15)]
        return schemas.make(typename, name="hcm", states=states, transition_from=states * 2,
                            transition_to=states * 2, transition_condition=["condition"] * 30, current="WALKING")
    if name == "ball_in_image":
        cand = schemas.make(BallInImage)
        return schemas.make(typename, candidates=[cand] * 3)
    return schemas.make(typename)


def message_bytes(name: str, params: TelemetryParams) -> int:
    """Payload bytes of one typical message of a topic."""
    if name == IMAGE_TOPIC:
        if params.image_max_width <= 0:
            return PASS_THROUGH_IMAGE_BYTES
        width = params.image_max_width
        return int(width * width * 3 / 4 * IMAGE_BYTES_PER_PIXEL * (params.image_quality / 60)) + 600
    return len(schemas.encode(_typical(name)))


def on_wire(payload: int) -> int:
    """UDP payload bytes a message of ``payload`` bytes costs (fragments with header and tag each)."""
    chunks = max(1, math.ceil(payload / (1400 - OVERHEAD)))
    return payload + chunks * OVERHEAD


def _share(demands: dict[str, tuple[Priority, float]], budget: float) -> dict[str, float]:
    """What the byte budget grants each stream: weighted water-filling by priority, equal within a class."""
    granted = dict.fromkeys(demands, 0.0)
    left = {k: d for k, (_, d) in demands.items() if d > 0}
    remaining = budget
    while left and remaining > 1e-6:
        weights = {k: SHARES[demands[k][0]] / sum(1 for j in left if demands[j][0] == demands[k][0])
                   for k in left}
        total_weight = sum(weights.values())
        satisfied = {k for k in left if left[k] <= remaining * weights[k] / total_weight}
        if not satisfied:
            for k in left:
                granted[k] += remaining * weights[k] / total_weight
            break
        for k in satisfied:
            granted[k] += left[k]
            remaining -= left[k]
            del left[k]
    return granted


def estimate_bandwidth(config: dict[str, Any] | TelemetryParams | None = None) -> dict[str, float]:
    """Bytes/s per stream (topics, "overview", "stream_table") and "total", after the byte budget.

    ``config`` holds TelemetryNode parameters (missing ones take their defaults).
    """
    if isinstance(config, TelemetryParams):
        params = config
    else:
        fields = {f.name for f in dataclasses.fields(TelemetryParams)}
        unknown = set(config or {}) - fields
        if unknown:
            raise ValueError(f"telemetry has no parameter(s) {sorted(unknown)}")
        params = TelemetryParams(**(config or {}))
    demand = stream_demands(params)
    granted = _share(demand, float(params.budget_bytes_per_s))
    granted["total"] = sum(granted.values())
    return granted


def stream_demands(params: TelemetryParams) -> dict[str, tuple[Priority, float]]:
    """Bytes/s each stream would send without a budget, with its priority."""
    rates = parse_topics(params.topics)
    out = {name: (topic(name).priority, on_wire(message_bytes(name, params)) * hz) for name, hz in rates.items()}
    out["overview"] = (Priority.CRITICAL, on_wire(OVERVIEW_SIZE) * params.overview_hz)
    infos = [StreamInfo(i + 1, n, full_name(topic(n).type), schema_hash(topic(n).type), int(topic(n).priority), hz)
             for i, (n, hz) in enumerate(rates.items())]
    table = sum(on_wire(len(b)) for b in encode_stream_tables(infos, params.budget_bytes_per_s))
    out["stream_table"] = (Priority.CRITICAL, table / params.table_period_s)
    return out


def report(params: TelemetryParams) -> str:
    """A table for people: demand and granted bytes/s per stream."""
    demand = stream_demands(params)
    granted = estimate_bandwidth(params)
    lines = [f"{'stream':32} {'priority':>10} {'wants B/s':>12} {'gets B/s':>12}"]
    for name, (prio, want) in sorted(demand.items(), key=lambda kv: (kv[1][0], kv[0])):
        lines.append(f"{name:32} {prio.name:>10} {want:12.0f} {granted[name]:12.0f}")
    lines.append(f"{'total':32} {'':>10} {sum(d for _, d in demand.values()):12.0f} {granted['total']:12.0f}"
                 f"   (budget {params.budget_bytes_per_s} B/s of UDP payload)")
    return "\n".join(lines)
