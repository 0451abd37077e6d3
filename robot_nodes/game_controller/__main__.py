"""python -m robot_nodes.game_controller"""

from robot_nodes.game_controller.receiver import main

main()
