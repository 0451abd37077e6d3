"""One-way telemetry on the wire: the datagram format robots send and the receiver the team PC runs."""
