"""pitchside mitecom node."""
