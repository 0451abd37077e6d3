"""Who may send what on a team's secured bus: the Zenoh access control every member enforces on its links.

Members are told apart by the common name of their TLS certificate (mutual TLS: a link without a certificate
of the team's CA is refused before any message). On every link the receiving end checks the sender:

* a robot's processes write their own robot's keys, ``pitchside/<robot>/**`` (topics, parameter, service and
  action replies, their own queries), and nothing under another robot;
* the lab laptop may also send the dashboard's commands: ``cmd_vel`` and ``record_motor_goals`` to any robot,
  and parameter, service and action requests;
* every team member may subscribe (a viewer does only that);
* the router forwards what it has already checked at its own ingress, so members accept what it relays.

Anything else (``motor_goals`` from the laptop, ``motor_goals`` of robot1 from robot2, any message from a
viewer) is dropped where it arrives. Every member's file carries the rules, so a direct peer link
between two members is checked like a link through the router.
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from typing import Any

from robot_nodes.runtime import keys
from schemas.topics import topic

ALL_MESSAGES = ("put", "delete", "declare_subscriber", "query", "reply", "declare_queryable", "liveliness_token",
                "liveliness_query", "declare_liveliness_subscriber")
READ_MESSAGES = ("declare_subscriber", "declare_liveliness_subscriber", "liveliness_query")
OWN_ROBOT_MESSAGES = ("put", "delete", "query", "reply", "declare_queryable", "liveliness_token")
# what the dashboard publishes in the lab (teleop, the animation recorder); goals to the servos stay the HCM's
LAB_COMMAND_TOPICS = ("cmd_vel", "record_motor_goals")


class Role(enum.Enum):
    ROUTER = "router"
    ROBOT = "robot"
    LAPTOP = "laptop"
    VIEWER = "viewer"


def access_control(members: Mapping[str, Role]) -> dict[str, Any]:
    """Zenoh's ``access_control`` section for a team (member name -> role); deny unless a rule allows."""
    everything = [keys.topic_key("*", "**")]
    rules = [
        _rule("team-subscribes", READ_MESSAGES, "ingress", everything),
        _rule("team-receives", ALL_MESSAGES, "egress", everything),
        _rule("router-relays", ALL_MESSAGES, "ingress", everything),
        _rule("lab-commands", ("put",), "ingress", [keys.topic_key("*", topic(t).name) for t in LAB_COMMAND_TOPICS]),
        _rule("lab-requests", ("query",), "ingress",
              [keys.params_key("*", "**"), keys.service_key("*", "**"), keys.action_key("*", "*", "goal"),
               keys.action_key("*", "*", "cancel")]),
    ]
    # no certificate names: any member of the team (the CA already kept everyone else off the link)
    subjects: list[dict[str, Any]] = [{"id": "team"}]
    policies = [{"id": "team", "rules": ["team-subscribes", "team-receives"], "subjects": ["team"]}]

    def grant(policy: str, names: list[str], rule_ids: list[str]) -> None:
        if names:  # Zenoh refuses an empty list of names
            subjects.append({"id": policy, "cert_common_names": sorted(names)})
            policies.append({"id": policy, "rules": rule_ids, "subjects": [policy]})

    grant("router", [n for n, r in members.items() if r is Role.ROUTER], ["router-relays"])
    grant("lab", [n for n, r in members.items() if r is Role.LAPTOP], ["lab-commands", "lab-requests"])
    for name in sorted(n for n, r in members.items() if r is Role.ROBOT):
        rules.append(_rule(f"robot-{name}", OWN_ROBOT_MESSAGES, "ingress", [keys.topic_key(name, "**")]))
        grant(f"robot-{name}", [name], [f"robot-{name}"])
    return {"enabled": True, "default_permission": "deny", "rules": rules, "subjects": subjects,
            "policies": policies}


def _rule(rule_id: str, messages: tuple[str, ...], flow: str, key_exprs: list[str]) -> dict[str, Any]:
    return {"id": rule_id, "messages": list(messages), "flows": [flow], "permission": "allow", "key_exprs": key_exprs}
