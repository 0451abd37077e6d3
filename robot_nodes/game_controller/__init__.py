"""pitchside game_controller node."""
