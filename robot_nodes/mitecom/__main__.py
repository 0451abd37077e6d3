"""python -m robot_nodes.mitecom"""

from robot_nodes.mitecom.node import main

main()
