"""How the dashboard sees any ROS 2 robot: the domains it listens to, the team file naming robots by domain, the
team profile mapping a team's topics onto panels, and the route of each data key to the hub."""

from server.profiles.profile import DEFAULT_BY_TYPE, SHIPPED, PanelTopic, ProfileError, TeamProfile, load_profile
from server.profiles.routes import Refusal, Route, RouteRefused, route
from server.profiles.team import Ros2Setup, load_team, parse_domains
from server.profiles.translate import translate

__all__ = [
    "DEFAULT_BY_TYPE",
    "SHIPPED",
    "PanelTopic",
    "ProfileError",
    "Refusal",
    "Ros2Setup",
    "Route",
    "RouteRefused",
    "TeamProfile",
    "load_profile",
    "load_team",
    "parse_domains",
    "route",
    "translate",
]
