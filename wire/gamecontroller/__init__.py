"""The RoboCup GameController's wire: state packets (HSL v20/v19, HL v12), robots' return and status packets, the
GameState a packet means for one robot, and the monitor interface. Below both the game_controller node and the
dashboard server (its GameController monitor source)."""
