"""The robot's nodes by name: the module that runs one alone, the class a composed process builds.

A team's own node is named the same ways: ``package.module`` runs alone (its ``__main__`` calls ``run``), and
``package.module:NodeClass`` can also be composed with others.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from robot_nodes.runtime import Node

# how a composed process (robot_nodes/compose.py) and its supervisor (launch.py) speak: kept here, where the
# supervisor reads them without loading the runtime
FAILED_NODE_EXIT = 64  # exit code of a composed process whose node i failed: FAILED_NODE_EXIT + i
ROBOT_SEPARATOR = "+"  # between the robots of one process on the command line
MOTION_NODES = ["hcm", "animation", "pause", "speaker"]  # beside cm730 and walking in every robot's motion chain


@dataclass(frozen=True)
class NodeEntry:
    """Where one node lives: run alone with ``python -m module``, composed from ``node_class``."""

    module: str
    node_class: str  # "module:Class"

    def load(self) -> type[Node]:
        """The node class (imports its module): ValueError if it is not a pitchside Node."""
        from robot_nodes.runtime import Node  # the runtime (Zenoh, the messages) only when a node is wanted

        module_name, _, class_name = self.node_class.partition(":")
        cls = getattr(importlib.import_module(module_name), class_name, None)
        if not (isinstance(cls, type) and issubclass(cls, Node)):
            raise ValueError(f"{self.node_class} is not a pitchside Node class")
        return cls


NODES: dict[str, NodeEntry] = {
    "cm730": NodeEntry("robot_nodes.cm730", "robot_nodes.cm730.node:Cm730Node"),
    "hcm": NodeEntry("robot_nodes.hcm", "robot_nodes.hcm.node:HcmNode"),
    "animation": NodeEntry("robot_nodes.animation", "robot_nodes.animation.node:AnimationNode"),
    "walking": NodeEntry("robot_nodes.walking", "robot_nodes.walking.node:WalkingNode"),
    "pause": NodeEntry("robot_nodes.hcm.pause", "robot_nodes.hcm.pause:PauseNode"),
    "speaker": NodeEntry("robot_nodes.speaker", "robot_nodes.speaker.node:SpeakerNode"),
    "game_controller": NodeEntry("robot_nodes.game_controller",
                                 "robot_nodes.game_controller.receiver:GameControllerNode"),
    "mitecom": NodeEntry("robot_nodes.mitecom", "robot_nodes.mitecom.node:MitecomNode"),
    "telemetry": NodeEntry("robot_nodes.telemetry", "robot_nodes.telemetry.sender:TelemetryNode"),
    "head": NodeEntry("robot_nodes.head", "robot_nodes.head.node:HeadNode"),
    "kick": NodeEntry("robot_nodes.kick", "robot_nodes.kick.node:KickNode"),
    "behavior": NodeEntry("robot_nodes.behavior", "robot_nodes.behavior.node:BehaviorNode"),
}
NODE_MODULES: dict[str, str] = {name: entry.module for name, entry in NODES.items()}


def entry(name: str) -> NodeEntry:
    """A node of the table, or a team's own: ``package.module`` or ``package.module:NodeClass``."""
    if name in NODES:
        return NODES[name]
    module, _, cls = name.partition(":")
    return NodeEntry(module, name if cls else "")


def node_label(name: str) -> str:
    """The short name a node goes by in logs and process names (a table name, else the class or module)."""
    return name if name in NODES else (name.rpartition(":")[2] or name.rpartition(".")[2])
