"""The animation node: plays keyframe animations (wire.animation: the Bit-Bots file format and its player)."""
