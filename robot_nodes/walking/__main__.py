"""python -m robot_nodes.walking"""

from robot_nodes.runtime import run
from robot_nodes.walking.node import WalkingNode

run(WalkingNode)
