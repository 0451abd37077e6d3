"""Security at the venue: which hosts and origins the dashboard answers, who may control, what input it takes.

The team laptop shares a network with other teams and visitors, and its browser opens other sites. Everything
that decides whether a request may reach the routers lives here (DESIGN.md section 11); the routers only say
which of their endpoints control robots.
"""

from server.security.credentials import Credentials
from server.security.folders import AllowedFolders, FolderError
from server.security.guard import VenueGuard, VenuePolicy
from server.security.hosts import AllowedHosts, host_name_of
from wire.json_limits import JsonLimitError, check_json_depth, loads_limited

__all__ = [
    "AllowedFolders",
    "AllowedHosts",
    "Credentials",
    "FolderError",
    "JsonLimitError",
    "VenueGuard",
    "VenuePolicy",
    "check_json_depth",
    "host_name_of",
    "loads_limited",
]
