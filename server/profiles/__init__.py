"""How the dashboard sees any ROS 2 robot: the domains it listens to, the team file naming robots by domain, the
team profile mapping a team's topics onto panels, and the route of each data key to the hub.

Import the modules themselves (profile, routes, team, translate, flags): ``flags`` is read by a command's --help,
which must not load the image and message code the others need.
"""
