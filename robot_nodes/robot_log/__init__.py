"""The robot's own full-rate log in a match, its ring of files, and serving them to `pitchside logs pull`."""
