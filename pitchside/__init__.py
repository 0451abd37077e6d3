"""The pitchside command line."""
