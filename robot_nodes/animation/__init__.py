"""pitchside animation node."""
