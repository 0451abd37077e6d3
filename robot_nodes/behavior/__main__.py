from robot_nodes.behavior.node import BehaviorNode
from robot_nodes.runtime import run

if __name__ == "__main__":
    run(BehaviorNode)
