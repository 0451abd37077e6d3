"""/api/ros2/robots: the ROS 2 robots the liveliness tokens show in the listened domains (server.sources.ros2_robots),
each with its nodes and the topics they publish, and whether the dashboard shows each topic (on which panel topic)
or why not ("definition missing", a hash that does not match). Reading only."""

from __future__ import annotations

from fastapi import APIRouter, Depends
from pydantic import BaseModel

from server.deps import get_state
from server.sources.live import LiveZenohSource
from server.state import ServerState

router = APIRouter(prefix="/api/ros2", tags=["ros2"])


class Ros2Topic(BaseModel):
    name: str  # fully qualified, as ros2 topic list shows it: /joint_states, /robot1/joint_states
    type: str  # as the publisher's token names it: bitbots_msgs/msg/RobotControlState
    type_hash: str
    status: str  # "shown", or why not: "definition missing", "type hash does not match ..."
    panel: str | None  # the dashboard topic it is shown on (a panel's, or its own name)


class Ros2Robot(BaseModel):
    robot: str  # the team file's name of its domain, or its namespace
    domain: int
    nodes: list[str]
    topics: list[Ros2Topic]


class Ros2Robots(BaseModel):
    domains: list[int]  # the domains listened to
    profile: str  # the team profile's name
    robots: list[Ros2Robot]
    why_empty: str = ""  # the live source is off, or in match mode


@router.get("/robots")
def ros2_robots(state: ServerState = Depends(get_state)) -> Ros2Robots:
    live = state.sources.sources.get("live")
    setup = state.config.ros2
    if not isinstance(live, LiveZenohSource) or live.robots is None:
        why = "match mode: no Zenoh session" if state.config.match_mode else "the live Zenoh source is not running"
        return Ros2Robots(domains=list(setup.listened()), profile=setup.profile.name, robots=[], why_empty=why)
    return Ros2Robots(domains=list(setup.listened()), profile=setup.profile.name,
                      robots=[Ros2Robot.model_validate(robot) for robot in live.robots.robots()])
