"""Simulated robots for acceptance tests: one MuJoCo world, every robot's real nodes on one session (as a composed
process runs them), and a separate client session that listens and publishes like a tool on the bus would.

The nodes follow the world's clock in lockstep (robot_nodes/runtime/clock.py): the world waits for them every
10 ms of simulated time, so a test sees the same play on an idle machine and on a CI machine running two workers
beside it; the test's own timeouts stay on the wall clock and its judgements of time use ``sim_time()``."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

import yaml
import zenoh

import robots
import schemas
from robot_nodes.catalog import entry
from robot_nodes.cm730.node import Cm730Node
from robot_nodes.cm730.sim_backend import MujocoBackend
from robot_nodes.runtime import BusConfig, Node, open_session
from robot_nodes.runtime.clock import CLOCK_PERIOD_S, SimClock
from robot_nodes.sim import PhysicsConfig, Placement, RobotHandle, SimRunner, SimWorld
from schemas.codec import Message
from tests.waiting import wait_for
from wire.keys import topic_key

# the servo bus as in a match, without images (nobody looks); perception runs for every robot
CM730 = {"publish_rate": 100.0, "render_camera": False, "camera_rate": 10.0}
# nodes, MuJoCo and the test share a loaded 2-core machine: a 0.5 s gap in joint_states is no servo failure here
PATIENT_HCM = {"imu_timeout_s": 2.0, "motor_timeout_s": 2.0}
# the simulated robot is the Minibot: its HCM as its params.yaml sets it (getting up from a side)
MINIBOT_HCM = yaml.safe_load(robots.params_file("minibot").read_text()).get("hcm", {})


def pass_time(clock: SimClock, seconds: float) -> None:
    """Until ``seconds`` of ``clock``'s simulated time have passed (the world may be slower than the wall clock)."""
    until = clock.now() + seconds
    wait_for(lambda: clock.now() >= until, 20.0 + 20.0 * seconds, 0.01, what=f"{seconds} s of simulated time to pass")


class Listener:
    """Every message of one robot's topic, decoded, with its arrival time (by ``clock``: the simulated seconds of
    SimRobots' listeners)."""

    def __init__(self, session: zenoh.Session, robot: str, topic: str,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.topic = topic
        self.messages: list[tuple[float, Any]] = []
        self._lock = threading.Lock()
        typename = schemas.topic(topic).type

        def on_sample(sample: zenoh.Sample) -> None:
            msg = schemas.decode(sample.payload.to_bytes(), typename)
            with self._lock:
                self.messages.append((clock(), msg))

        self._sub = session.declare_subscriber(topic_key(robot, topic), on_sample)

    def last(self) -> Any:
        with self._lock:
            return self.messages[-1][1] if self.messages else None

    def since(self, t: float) -> list[Any]:
        with self._lock:
            return [m for at, m in self.messages if at >= t]

    def first_time_since(self, t: float) -> float | None:
        with self._lock:
            return next((at for at, _ in self.messages if at >= t), None)

    def close(self) -> None:
        self._sub.undeclare()


class SimRobots:
    """``n`` robots (robot1..robotN) in one world, each with its cm730 and the named nodes of the catalog."""

    def __init__(self, bus: BusConfig, n: int = 1, nodes: tuple[str, ...] = ("animation", "hcm"),
                 overrides: dict[str, dict[str, Any]] | None = None,
                 per_robot: Callable[[int], dict[str, dict[str, Any]]] | None = None,
                 placements: list[Placement] | None = None, physics: PhysicsConfig | None = None,
                 prepare: Callable[[SimWorld], None] | None = None) -> None:
        """prepare: changes the world's model before anything runs (a test of other physics)."""
        self.world = SimWorld(n_robots=n, placements=placements, physics=physics)
        if prepare is not None:
            prepare(self.world)
        self.clock = SimClock(lockstep=True)
        self._started = time.monotonic()
        self.runner = SimRunner(self.world)
        self.runner.tick_clock(CLOCK_PERIOD_S, self.clock.advance)
        self.runner.start()
        self.session = open_session(bus)
        self.client = open_session(bus)
        self.nodes: dict[str, dict[str, Node]] = {}
        self._listeners: list[Listener] = []
        self._publishers: dict[tuple[str, str], Any] = {}
        overrides = overrides or {}
        for i, handle in enumerate(self.world.robots):
            own = per_robot(i) if per_robot else {}
            params = {"hcm": {**MINIBOT_HCM, **PATIENT_HCM}, **overrides}
            # the first robot's node alone sends the ground truth (every robot's pose is in it)
            cm730 = {**CM730, **({} if i == 0 else {"ground_truth_rate": 0.0}), **params.get("cm730", {}),
                     **own.get("cm730", {})}
            robot_nodes: dict[str, Node] = {"cm730": Cm730Node(
                robot_id=handle.robot_id, bus=self.session, overrides=cm730,
                backend=MujocoBackend(self.world, handle, self.runner), clock=self.clock)}
            for name in nodes:
                cls = entry(name).load()
                robot_nodes[name] = cls(robot_id=handle.robot_id, bus=self.session, clock=self.clock,
                                        overrides={**params.get(name, {}), **own.get(name, {})})
            self.nodes[handle.robot_id] = robot_nodes
        for robot_nodes in self.nodes.values():
            for node in robot_nodes.values():
                node.start()

    # -- the world ----------------------------------------------------------------------------------------
    def robot(self, robot_id: str = "robot1") -> RobotHandle:
        return self.world.robot(robot_id)

    def sim_time(self) -> float:
        """The world's simulated seconds: the time the robots' nodes live in."""
        return self.clock.now()

    def pass_time(self, seconds: float) -> None:
        pass_time(self.clock, seconds)

    def pose(self, robot_id: str = "robot1") -> tuple[float, float, float]:
        with self.world.lock:
            return self.world.robot(robot_id).pose2d()

    def ball(self) -> tuple[float, float]:
        with self.world.lock:
            b = self.world.ball_position()
        return float(b[0]), float(b[1])

    def set_ball(self, x: float, y: float) -> None:
        with self.world.lock:
            self.world.set_ball(x, y)

    def upright(self, robot_id: str = "robot1") -> bool:
        with self.world.lock:
            return self.world.robot(robot_id).uprightness() > 0.9

    # -- the bus ------------------------------------------------------------------------------------------
    def listen(self, topic: str, robot_id: str = "robot1") -> Listener:
        """Arrival times in simulated seconds (sim_time)."""
        listener = Listener(self.client, robot_id, topic, self.clock.now)
        self._listeners.append(listener)
        return listener

    def publish(self, topic: str, msg: Message, robot_id: str = "robot1") -> None:
        key = (robot_id, topic)
        if key not in self._publishers:
            self._publishers[key] = self.client.declare_publisher(topic_key(robot_id, topic))
        self._publishers[key].put(schemas.encode(msg))

    def wait_controllable(self, robot_id: str = "robot1", timeout: float = 40.0) -> None:
        """Until the HCM has played walkready and says CONTROLLABLE (0) or WALKING (10)."""
        states = self.listen("robot_state", robot_id)
        wait_for(lambda: states.last() is not None and states.last().state in (0, 10) and self.upright(robot_id),
                 timeout, what=f"{robot_id} CONTROLLABLE and upright")

    def close(self) -> None:
        for listener in self._listeners:
            listener.close()
        for pub in self._publishers.values():
            pub.undeclare()
        for robot_nodes in self.nodes.values():
            for node in reversed(list(robot_nodes.values())):
                node.shutdown()
        self.runner.stop()
        wall = time.monotonic() - self._started
        print(f"\nworld: {self.clock.now():.1f} s simulated in {wall:.1f} s ({self.clock.now() / wall:.2f} x real "
              f"time), {self.clock.lockstep_timeouts} lockstep waits given up")
        self.client.close()
        self.session.close()
