"""The Foxglove/Lichtblick layout that ships with pitchside (foxglove_layout.json beside this module), for one robot.

A layout is the apps' own JSON (``configById``: each panel's settings by panel id; ``layout``: the split tree of panel
ids; ``globalVariables``, ``userNodes``, ``playbackConfig``), what "Import from file" in Foxglove and Lichtblick reads.
This one shows the demo's robot1: the 3D panel with the robot from its robot_description and /tf and its markers,
the camera image with the detections drawn over it, plots of the leg joints' efforts and the IMU, the HCM's state
over time, the nodes' diagnostics and their log (rosout). For another robot every ``robot1`` in it becomes that
robot's id (a name of letters, digits, '_' and '-', so the JSON stays valid).
"""

from __future__ import annotations

from importlib import resources
from typing import Any

LAYOUT_FILE = "foxglove_layout.json"
LAYOUT_ROBOT = "robot1"


def layout_text(robot: str = LAYOUT_ROBOT) -> str:
    """The layout's JSON text for ``robot`` (a checked robot id: server.deps.valid_robot)."""
    text = resources.files(__package__).joinpath(LAYOUT_FILE).read_text(encoding="utf-8")
    return text.replace(LAYOUT_ROBOT, robot)


def layout_topics(layout: dict[str, Any]) -> set[str]:
    """Every topic the layout's panels read (message paths cut at their first field), for the tests and the docs."""
    topics: set[str] = set()
    for config in layout["configById"].values():
        image = config.get("imageMode", {})
        topics |= {t for t in (image.get("imageTopic"), config.get("topicToRender")) if t}
        topics |= set(image.get("annotations", {}))
        topics |= set(config.get("topics", {}))
        topics |= {layer["topic"] for layer in config.get("layers", {}).values() if layer.get("sourceType") == "topic"}
        topics |= {path["value"].split(".", 1)[0] for path in config.get("paths", [])}
    return topics

