"""Who may send what on a team's secured bus: the Zenoh access control every member enforces on its links.

Machines reach each other only router to router (README, "Several machines"): each robot's router links to the
team laptop's router over mutual TLS, and members are told apart by the common name of their TLS certificate (a
link without a certificate of the team's CA is refused before any message). The team router checks everything
that comes in from another machine:

* a robot (its router relays only its own nodes) writes its own robot's keys, ``<domain>/<robot>/**`` (its
  topics, in rmw_zenoh's layout) and ``pitchside/<robot>/**`` (parameter, service and action replies, its own
  queries), and nothing under another robot's; it may declare tokens of the domain's ROS 2 graph
  (``@ros2_lv/<domain>/**``, which name their robot inside but are not checked per robot: a stranger's tokens
  could mislead ``ros2 node list``, never move data) and ``/parameter_events`` (which names its node inside: a
  robot could announce a change of another robot's node that did not happen, never make one);
* the lab laptop may also send the dashboard's commands: ``cmd_vel`` and ``record_motor_goals`` to any robot,
  and parameter, service and action requests (ROS 2 service calls are queries on ``<domain>/<robot>/**``);
* every team member may subscribe (a viewer does only that);
* the team router forwards only what it has checked at its own ingress, so members accept what it relays.

Anything else (``motor_goals`` from the laptop, ``motor_goals`` of robot1 from robot2, any message from a
viewer) is dropped where it arrives, so a member that deletes the rules from its own file gains nothing.

A robot's own router (``robot_router_access_control``) listens on loopback only: its nodes join it in plain TCP
on the robot, which is trusted, and may write the robot's own keys; it hears the team router and nobody else.
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from typing import Any

from schemas.topics import topic
from wire import keys

ALL_MESSAGES = ("put", "delete", "declare_subscriber", "query", "reply", "declare_queryable", "liveliness_token",
                "liveliness_query", "declare_liveliness_subscriber")
READ_MESSAGES = ("declare_subscriber", "declare_liveliness_subscriber", "liveliness_query")
OWN_ROBOT_MESSAGES = ("put", "delete", "query", "reply", "declare_queryable", "liveliness_token")
# what the dashboard publishes in the lab (teleop, the animation recorder); goals to the servos stay the HCM's
LAB_COMMAND_TOPICS = ("cmd_vel", "record_motor_goals")
# a robot's nodes reach its router in plain TCP on the loopback interface (robots run Linux: "lo")
LOOPBACK_INTERFACE = "lo"


class Role(enum.Enum):
    ROUTER = "router"
    ROBOT = "robot"
    LAPTOP = "laptop"
    VIEWER = "viewer"


def access_control(members: Mapping[str, Role]) -> dict[str, Any]:
    """Zenoh's ``access_control`` section of the team router and of the laptops' and viewers' files (member name
    -> role); deny unless a rule allows."""
    rules = [*_common_rules(), _lab_commands(), _lab_requests()]
    # no certificate names: any member of the team (the CA already kept everyone else off the link)
    subjects: list[dict[str, Any]] = [{"id": "team"}]
    policies = [{"id": "team", "rules": ["team-subscribes", "team-receives"], "subjects": ["team"]}]

    def grant(policy: str, names: list[str], rule_ids: list[str]) -> None:
        if names:  # Zenoh refuses an empty list of names
            subjects.append({"id": policy, "cert_common_names": sorted(names)})
            policies.append({"id": policy, "rules": rule_ids, "subjects": [policy]})

    grant("router", _routers(members), ["router-relays"])
    grant("lab", [n for n, r in members.items() if r is Role.LAPTOP], ["lab-commands", "lab-requests"])
    for name in sorted(n for n, r in members.items() if r is Role.ROBOT):
        rules.append(_own_robot(name))
        grant(f"robot-{name}", [name], [f"robot-{name}"])
    return _section(rules, subjects, policies)


def robot_router_access_control(robot: str, members: Mapping[str, Role]) -> dict[str, Any]:
    """The ``access_control`` of robot's own router: its nodes on the robot (plain TCP on loopback) write the
    robot's keys; the team router's links (certificate common name) relay; any other link is neither heard nor
    served, so a router that only poses as the team's (any member's certificate) gets nothing either way.

    It names no other member than the team router: adding robots or laptops leaves the robot's file as it is.
    """
    rules = [*_common_rules(), _own_robot(robot)]
    subjects = [{"id": "team-router", "cert_common_names": sorted(_routers(members))},
                {"id": "robot-nodes", "interfaces": [LOOPBACK_INTERFACE], "link_protocols": ["tcp"]}]
    policies = [{"id": "team-router", "rules": ["team-subscribes", "team-receives", "router-relays"],
                 "subjects": ["team-router"]},
                {"id": "robot-nodes", "rules": ["team-subscribes", "team-receives", f"robot-{robot}"],
                 "subjects": ["robot-nodes"]}]
    return _section(rules, subjects, policies)


def _common_rules() -> list[dict[str, Any]]:
    # the data, the ROS 2 graph, and pitchside's own keys (parameters, services, actions, node graph)
    everything = [keys.topic_key("*", "**"), keys.graph_tokens_key(), f"{keys.PREFIX}/*/**"]
    return [_rule("team-subscribes", READ_MESSAGES, "ingress", everything),
            _rule("team-receives", ALL_MESSAGES, "egress", everything),
            _rule("router-relays", ALL_MESSAGES, "ingress", everything)]


def _lab_commands() -> dict[str, Any]:
    return _rule("lab-commands", ("put",), "ingress", [keys.topic_key("*", topic(t).name) for t in LAB_COMMAND_TOPICS])


def _lab_requests() -> dict[str, Any]:
    return _rule("lab-requests", ("query",), "ingress",
                 # ROS 2 service calls (parameter services, the table's services) are queries on the robots' keys
                 [keys.topic_key("*", "**"), keys.action_key("*", "*", "goal"), keys.action_key("*", "*", "cancel")])


def _own_robot(robot: str) -> dict[str, Any]:
    return _rule(f"robot-{robot}", OWN_ROBOT_MESSAGES, "ingress",
                 [keys.topic_key(robot, "**"), keys.graph_tokens_key(), f"{keys.PREFIX}/{robot}/**",
                  f"{keys.domain_id()}/parameter_events/**"])  # ROS 2's one topic of every node's changes


def _routers(members: Mapping[str, Role]) -> list[str]:
    return [n for n, r in members.items() if r is Role.ROUTER]


def _section(rules: list[dict[str, Any]], subjects: list[dict[str, Any]],
             policies: list[dict[str, Any]]) -> dict[str, Any]:
    return {"enabled": True, "default_permission": "deny", "rules": rules, "subjects": subjects,
            "policies": policies}


def _rule(rule_id: str, messages: tuple[str, ...], flow: str, key_exprs: list[str]) -> dict[str, Any]:
    return {"id": rule_id, "messages": list(messages), "flows": [flow], "permission": "allow", "key_exprs": key_exprs}
