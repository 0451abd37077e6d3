from robot_nodes.kick.node import KickNode
from robot_nodes.runtime import run

if __name__ == "__main__":
    run(KickNode)
