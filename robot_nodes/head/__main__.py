from robot_nodes.head.node import HeadNode
from robot_nodes.runtime import run

if __name__ == "__main__":
    run(HeadNode)
