"""The behaviour: a small state machine per robot that plays the game (roles through team communication)."""
