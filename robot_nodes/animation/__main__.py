"""Process entry point: ``python -m robot_nodes.animation --robot-id robot1``."""

from __future__ import annotations

from robot_nodes.animation.node import AnimationNode
from robot_nodes.runtime import run

if __name__ == "__main__":
    run(AnimationNode)
