"""pitchside telemetry node."""
