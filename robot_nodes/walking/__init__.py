"""pitchside walking node."""
