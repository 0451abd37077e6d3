"""Small nodes that tests start as real processes: ``python -m tests.proc_nodes talker --connect ...``."""

from __future__ import annotations

import sys
from dataclasses import dataclass

import schemas
from robot_nodes.runtime import Node, header, param, run


@dataclass
class TalkerParams:
    rate_hz: float = param(200.0, range=(1.0, 2000.0), doc="messages per second")
    label: str = param("talker", doc="written into header.frame_id")


class Talker(Node):
    """Publishes joint_states whose single position is a sequence number."""

    name = "talker"
    Params = TalkerParams

    def setup(self) -> None:
        self.seq = 0
        self.pub = self.publisher("joint_states")
        self.tick_timer = self.timer(self.tick, rate_hz=self.params.rate_hz)

    def on_parameters_changed(self, changed: dict[str, object]) -> None:
        if "rate_hz" in changed:
            self.tick_timer.set_rate(self.params.rate_hz)

    def tick(self) -> None:
        self.seq += 1
        self.pub.publish(schemas.make("sensor_msgs/msg/JointState", header=header(self.params.label),
                                      name=["seq"], position=[float(self.seq)]))


class Echo(Node):
    """Answers every joint_states with a robot_state whose state is the sequence number (mod 256): a subscriber
    that publishes, so a composed process shows both directions."""

    name = "echo"

    def setup(self) -> None:
        self.received = 0
        self.pub = self.publisher("robot_state")
        self.subscribe("joint_states", self.on_joint_states)

    def on_joint_states(self, msg: object) -> None:
        self.received += 1
        seq = int(msg.position[0])  # type: ignore[attr-defined]
        self.pub.publish(schemas.make("humanoid_league_msgs/msg/RobotControlState", state=seq % 256))


class BrokenAtStart(Node):
    """A node whose setup fails: what the supervisor must name when it restarts a composed process."""

    name = "broken"

    def setup(self) -> None:
        raise RuntimeError("this node never starts")


class LeavesSoon(Node):
    """A node that shuts itself down shortly after it started: a composed process must end, naming it."""

    name = "leaves_soon"

    def setup(self) -> None:
        self.timer(self.shutdown, rate_hz=5.0, name="leave")


NODES = {"talker": Talker, "echo": Echo}

if __name__ == "__main__":
    run(NODES[sys.argv[1]], sys.argv[2:])
