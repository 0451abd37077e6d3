"""pitchside hcm node."""
