"""Who may send what on a team's secured bus: the Zenoh access control every member enforces on its links.

Machines reach each other only router to router (README, "Several machines"): each robot's router links to the
team laptop's router over mutual TLS, and members are told apart by the common name of their TLS certificate (a
link without a certificate of the team's CA is refused before any message). The team router checks everything
that comes in from another machine:

* a robot (its router relays only its own nodes) writes its own namespace in rmw_zenoh's layout,
  ``<domain>/<robot>/**`` (its topics and services, and under ``@adv`` the caches of its latched topics), the
  root-namespace topics every ROS 2 node writes (``/rosout``, ``/parameter_events``), and nothing under another
  robot's; it may declare tokens of the domain's ROS 2 graph (``@ros2_lv/<domain>/**``, which name their robot
  inside but are not checked per robot: a stranger's tokens could mislead ``ros2 node list``, never move data);
* the lab laptop may also send the dashboard's commands: ``cmd_vel`` and ``record_motor_goals`` to any robot,
  and parameter, service and action requests (ROS 2 service calls are queries on the domain's keys);
* every team member may subscribe, to anything (``**`` too: it receives only what members were allowed to put), and
  ask latched topics' caches (a transient local subscriber's query); a viewer does only that;
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
# what every member may do: subscribe (and ask latched topics' caches), receive, pass subscriptions on
TEAM_RULES = ["team-subscribes", "team-reads-latched", "team-receives", "team-forwards-subscriptions"]
# topics of the root namespace that every ROS 2 node writes, whatever its robot
ROOT_TOPICS = ("rosout", "parameter_events")
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
    policies = [{"id": "team", "rules": TEAM_RULES, "subjects": ["team"]}]

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
    policies = [{"id": "team-router", "rules": [*TEAM_RULES, "router-relays"], "subjects": ["team-router"]},
                {"id": "robot-nodes", "rules": [*TEAM_RULES, f"robot-{robot}"], "subjects": ["robot-nodes"]}]
    return _section(rules, subjects, policies)


def _data(domain: int) -> str:
    """Every data key of the domain in rmw_zenoh's layout: the robots' namespaces and the root's (/rosout)."""
    return f"{domain}/**"


def _caches(prefix: str) -> str:
    """The keys of zenoh-ext's advanced publishers and subscribers under ``prefix`` (latched topics: the cache a
    late subscriber queries, the liveliness that finds it). ``@adv`` is a verbatim chunk, so ``**`` never matches
    it: the rules name it."""
    return f"{prefix}/**/@adv/**"


def _common_rules() -> list[dict[str, Any]]:
    domain = keys.domain_id()
    # the domain's data with the latched topics' caches, the ROS 2 graph, and pitchside's own keys (parameters,
    # services, actions)
    everything = [_data(domain), _caches(str(domain)), keys.graph_tokens_key()]
    # a member may subscribe to anything, "**" included (every key but the verbatim ones): it receives only what
    # the team's members were allowed to put, so a subscription reaches nothing else; and it may ask a latched
    # topic's publisher for what it kept (transient local), which answers with data it could subscribe to anyway
    return [_rule("team-subscribes", READ_MESSAGES, "ingress", ["**", *everything]),
            _rule("team-reads-latched", ("query",), "ingress", [_caches(str(domain))]),
            _rule("team-receives", ALL_MESSAGES, "egress", everything),
            _rule("team-forwards-subscriptions", READ_MESSAGES, "egress", ["**"]),
            _rule("router-relays", ALL_MESSAGES, "ingress", everything)]


def _lab_commands() -> dict[str, Any]:
    return _rule("lab-commands", ("put",), "ingress", [keys.topic_key("*", topic(t).name) for t in LAB_COMMAND_TOPICS])


def _lab_requests() -> dict[str, Any]:
    # every ROS 2 service of the domain (parameters, actions' goals and cancels, manual_penalize: queryables on
    # rmw_zenoh's keys) and pitchside's own request keys
    return _rule("lab-requests", ("query",), "ingress",
                 [_data(keys.domain_id())])


def _own_robot(robot: str) -> dict[str, Any]:
    domain = keys.domain_id()
    # its namespace (topics, services, its latched topics' caches), the topics of the root namespace every ROS 2
    # node writes (/rosout, /parameter_events; the logger name in a record is not checked), its graph tokens
    own = [keys.topic_key(robot, "**"), _caches(f"{domain}/{robot}")]
    for shared in ROOT_TOPICS:
        own += [f"{domain}/{shared}/**", _caches(f"{domain}/{shared}")]
    return _rule(f"robot-{robot}", OWN_ROBOT_MESSAGES, "ingress",
                 [*own, keys.graph_tokens_key()])


def _routers(members: Mapping[str, Role]) -> list[str]:
    return [n for n, r in members.items() if r is Role.ROUTER]


def _section(rules: list[dict[str, Any]], subjects: list[dict[str, Any]],
             policies: list[dict[str, Any]]) -> dict[str, Any]:
    return {"enabled": True, "default_permission": "deny", "rules": rules, "subjects": subjects,
            "policies": policies}


def _rule(rule_id: str, messages: tuple[str, ...], flow: str, key_exprs: list[str]) -> dict[str, Any]:
    return {"id": rule_id, "messages": list(messages), "flows": [flow], "permission": "allow", "key_exprs": key_exprs}
