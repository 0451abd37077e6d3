"""The topic table: every topic pitchside nodes speak, and its message type.

Nodes are exchangeable because only these names and types are fixed (thesis ch. 4).
Zenoh key of a topic: rmw_zenoh's key of the ROS 2 topic ``/<robot_id>/<topic>`` (wire.keys.topic_key), or of
``/<topic>`` for a topic of the root namespace (``/rosout``).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum


class Priority(IntEnum):
    """How important a topic is when bandwidth is short (telemetry budget)."""

    CRITICAL = 0
    STATE = 1
    PERCEPTION = 2
    BULK = 3


@dataclass(frozen=True, slots=True)
class Topic:
    name: str
    type: str
    description: str
    priority: Priority = Priority.STATE
    # published only when something happens (an animation plays, the robot walks or talks): silence on it is
    # normal, so the dashboard shows its age but never calls it stale or lost
    event: bool = False
    # a ROS 2 name of its own outside the robot's namespace (/rosout, /clock, as ROS 2 has them): one topic for
    # every robot of the domain, the robot told by the message (a Log's logger name ``robot1.hcm``)
    root: bool = False
    # latched (ROS 2's transient local durability): the publisher keeps its last ``latched`` messages for
    # subscribers that join later (robot_description, tf_static); 0: volatile, a late subscriber gets the next one
    latched: int = 0


_HL = "humanoid_league_msgs/msg/"

_TABLE: tuple[Topic, ...] = (
        Topic("joint_states", "sensor_msgs/msg/JointState", "measured joint positions, cm730 -> all"),
        Topic("imu/data", "sensor_msgs/msg/Imu", "orientation, angular velocity, acceleration; cm730 -> hcm"),
        Topic("servo_data", _HL + "AdditionalServoData", "servo temperatures and voltage", Priority.PERCEPTION),
        Topic("servo_health", "pitchside_msgs/msg/ServoHealth",
              "servos that do not answer and the bus state, on change and every second; cm730 -> hcm, dashboard",
              Priority.CRITICAL),
        Topic("motor_goals", "trajectory_msgs/msg/JointTrajectory", "joint goals, hcm -> cm730", event=True),
        Topic("motor_torque", "sensor_msgs/msg/JointState",
              "servo torque on/off per joint: name lists joints, effort 1.0 = on, 0.0 = off (limp); hcm -> cm730",
              Priority.CRITICAL, event=True),
        Topic("walk_motor_goals", "trajectory_msgs/msg/JointTrajectory", "walking -> hcm", event=True),
        Topic("head_motor_goals", "trajectory_msgs/msg/JointTrajectory", "head behaviour -> hcm", event=True),
        Topic("record_motor_goals", "trajectory_msgs/msg/JointTrajectory", "animation recorder -> hcm", event=True),
        Topic("animation", _HL + "Animation", "keyframe animation steps, animation -> hcm", event=True),
        Topic("robot_state", _HL + "RobotControlState", "HCM state, hcm -> all", Priority.CRITICAL),
        Topic("hcm_graph", "pitchside_msgs/msg/StateMachineGraph", "HCM states, transitions, history"),
        Topic("head_mode", _HL + "HeadMode", "what the head looks for, behaviour -> head"),
        Topic("behavior_graph", "pitchside_msgs/msg/StateMachineGraph",
              "the behaviour's states, transitions, history (as hcm_graph); behaviour -> dashboard"),
        Topic("cmd_vel", "geometry_msgs/msg/Twist", "walk command, behaviour/teleop -> walking", event=True),
        Topic("walk_odometry", "nav_msgs/msg/Odometry", "walking -> localization", event=True),
        Topic("walking_active", "std_msgs/msg/Bool", "walking tells the HCM it is stepping"),
        Topic("gamestate", _HL + "GameState", "GameController state, game_controller -> all", Priority.CRITICAL),
        Topic("paused", "std_msgs/msg/Bool", "penalty/pause, pause logic -> hcm", Priority.CRITICAL),
        Topic("whistle", "std_msgs/msg/Bool",
              "the referee's whistle heard (true); a whistle detector -> game_controller, which starts PLAYING on it "
              "while the GameController still sends its delayed SET", Priority.CRITICAL, event=True),
        Topic("manual_penalty", "std_msgs/msg/Bool",
              "the robot's own manual penalty (its button, the manual_penalize service), on change and with paused; "
              "pause logic -> game_controller, which tells the GameController (MAN_PENALISE / MAN_UNPENALISE)",
              Priority.CRITICAL),
        Topic("team_data", _HL + "TeamData", "teammates' data, mitecom -> all", event=True),
        Topic("team_comm", "pitchside_msgs/msg/TeamCommStatus",
              "which teammates this robot hears, the age and loss of their messages; mitecom -> dashboard"),
        Topic("strategy", _HL + "Strategy", "role and action, behaviour -> mitecom"),
        Topic("speak", _HL + "Speak", "sentences for the speaker", Priority.PERCEPTION, event=True),
        Topic("camera/image/compressed", "sensor_msgs/msg/CompressedImage", "JPEG camera image", Priority.BULK),
        Topic("camera/camera_info", "sensor_msgs/msg/CameraInfo", "camera intrinsics", Priority.PERCEPTION),
        Topic("ball_in_image", _HL + "BallsInImage", "ball candidates in the image", Priority.PERCEPTION),
        Topic("goal_in_image", _HL + "GoalPartsInImage", "goal posts and bars in the image", Priority.PERCEPTION),
        Topic("obstacles_in_image", _HL + "ObstaclesInImage", "obstacles in the image", Priority.PERCEPTION),
        Topic("line_information_in_image", _HL + "LineInformationInImage", "field lines in the image",
              Priority.PERCEPTION),
        Topic("ball_relative", _HL + "BallRelative", "ball relative to the robot"),
        Topic("obstacles_relative", _HL + "ObstaclesRelative", "obstacles relative to the robot",
              Priority.PERCEPTION),
        Topic("goal_relative", _HL + "GoalRelative", "goal relative to the robot", Priority.PERCEPTION),
        Topic("line_information_relative", _HL + "LineInformationRelative", "field lines relative to the robot",
              Priority.PERCEPTION),
        Topic("position", _HL + "Position2D", "own position on the field"),
        Topic("ground_truth", "pitchside_msgs/msg/GroundTruth", "simulation ground truth poses"),
        Topic("clock", "rosgraph_msgs/msg/Clock",
              "the simulation's time, every 10 ms of it, ROS 2's /clock: one for every robot of the simulation; "
              "simulation -> the robots' nodes when they follow simulated time (ROS 2's use_sim_time)", root=True),
        Topic("clock_done", "std_msgs/msg/Header",
              "a process of the robot's nodes is done with the simulation's time in stamp (frame_id: which "
              "process); the robot's nodes -> the simulation, when it waits for them (a lockstep match)"),
        Topic("diagnostics", "diagnostic_msgs/msg/DiagnosticArray", "node health, every node -> dashboard"),
        Topic("rosout", "rcl_interfaces/msg/Log",
              "every node's log records (INFO and above, rate-limited per node), ROS 2's /rosout: one topic for every "
              "robot, the logger name <robot>.<node> tells whose; every node -> dashboard, recordings",
              Priority.PERCEPTION, event=True, root=True, latched=1000),
        Topic("robot_description", "std_msgs/msg/String",
              "the robot's URDF, latched (a late subscriber gets it); cm730 -> dashboard, 3D views", Priority.BULK,
              event=True, latched=1),
        Topic("tf_static", "tf2_msgs/msg/TFMessage",
              "the URDF's fixed joints as transforms, latched (robot_state_publisher's in ROS 2); cm730 -> 3D views",
              Priority.BULK, event=True, latched=1),
        Topic("overview", "pitchside_msgs/msg/RobotOverview",
              "one robot at a glance: telemetry's compact overview datagram, every tick; telemetry -> dashboard",
              Priority.CRITICAL),
)


def _by_name(topics: tuple[Topic, ...]) -> dict[str, Topic]:
    """The table by name; a topic defined twice is a mistake, not an override."""
    table: dict[str, Topic] = {}
    for t in topics:
        if t.name in table:
            raise ValueError(f"topic {t.name!r} is defined twice in the topic table")
        table[t.name] = t
    return table


TOPICS: dict[str, Topic] = _by_name(_TABLE)


@dataclass(frozen=True, slots=True)
class Action:
    name: str
    type: str  # e.g. humanoid_league_msgs/action/PlayAnimation; _Goal/_Result/_Feedback appended


@dataclass(frozen=True, slots=True)
class Service:
    name: str
    type: str  # e.g. humanoid_league_msgs/srv/ManualPenalize; _Request/_Response appended


ACTIONS: dict[str, Action] = {
    a.name: a
    for a in (
        Action("animation", "humanoid_league_msgs/action/PlayAnimation"),
        Action("kick", "humanoid_league_msgs/action/Kick"),
    )
}

SERVICES: dict[str, Service] = {
    s.name: s for s in (Service("manual_penalize", "humanoid_league_msgs/srv/ManualPenalize"),)
}


def topic(name: str) -> Topic:
    """A topic of the table; KeyError names the unknown topic."""
    try:
        return TOPICS[name]
    except KeyError:
        raise KeyError(f"topic {name!r} is not in the topic table (schemas/topics.py)") from None
