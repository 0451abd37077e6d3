"""What the robot nodes and the dashboard server both speak, below both: Zenoh keys and names, the bus's
configuration, the parameter, service and action protocols, the telemetry datagram and the animation file.

Nodes build on it (robot_nodes.runtime adds their loop, timers and servers); the server builds on it; neither
reaches into the other.
"""
