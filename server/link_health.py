"""Link health of every discovered robot: age, rate and (from telemetry) loss and budget share per stream."""

from __future__ import annotations

import time
from typing import Any

from server.state import ServerState
from wire import keys


def robot_status(age_s: float, stale_after_s: float, lost_after_s: float) -> str:
    if age_s >= lost_after_s:
        return "lost"
    return "stale" if age_s >= stale_after_s else "ok"


def robots_info(state: ServerState) -> list[dict[str, Any]]:
    """What GET /api/robots and the WebSocket "robots" frame carry (see server.protocol)."""
    now = time.monotonic()
    extra = state.sources.stream_health()
    config = state.config
    out = []
    for robot in sorted(state.hub.robots.values(), key=lambda r: r.robot):
        streams = {}
        for topic, stats in sorted(robot.streams.items()):
            age = now - stats.last_received
            entry: dict[str, Any] = {
                "msgtype": stats.typename,
                "source": stats.source,
                "count": stats.count,
                "rate_hz": round(stats.current_rate(now), 2),
                "age_s": round(age, 3),
            }
            if stats.late:  # arrived late after a link cut: recorded, never shown as live
                entry["late"] = stats.late
            entry.update(extra.get((robot.robot, topic), {}))
            streams[topic] = entry
        age = now - robot.last_received
        out.append({
            "robot": robot.robot,
            "first_seen": robot.first_seen,
            "age_s": round(age, 3),
            "status": robot_status(age, config.stale_after_s, config.lost_after_s),
            "streams": streams,
            "replayed": keys.is_replayed(robot.robot),  # a robot of the open replay, never a live one
        })
        if keys.is_replayed(robot.robot):
            out[-1]["log_robot"] = keys.robot_in_log(robot.robot)  # as the log's messages name it
    return out
