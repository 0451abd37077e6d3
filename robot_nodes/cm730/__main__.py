"""Process entry: ``python -m robot_nodes.cm730 [--robot-id robot1] [--set backend=dynamixel]``."""

from robot_nodes.cm730.node import Cm730Node
from robot_nodes.runtime import run

if __name__ == "__main__":
    run(Cm730Node)
