"""The Kick action: the last small steps to the ball, the foot by the ball's side, a kick animation via the HCM."""
