"""Process entry point: ``python -m robot_nodes.speaker --robot-id robot1``."""

from __future__ import annotations

from robot_nodes.runtime import run
from robot_nodes.speaker.node import SpeakerNode

if __name__ == "__main__":
    run(SpeakerNode)
