"""Recording what the hub sees into MCAP logs: one session per file series, matches split per half."""
