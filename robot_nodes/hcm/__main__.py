"""python -m robot_nodes.hcm"""

from robot_nodes.hcm.node import HcmNode
from robot_nodes.runtime import run

run(HcmNode)
