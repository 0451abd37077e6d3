"""What the robot nodes and the dashboard server both speak, below both: Zenoh keys and names, the bus's
configuration, the parameter, service and action protocols, the telemetry datagram, the animation file and the
RoboCup GameController's packets (gamecontroller).

Nodes build on it (robot_nodes.runtime adds their loop, timers and servers); the server builds on it; neither
reaches into the other.
"""
