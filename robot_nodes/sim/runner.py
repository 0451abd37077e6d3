"""SimRunner: steps a SimWorld in real time (or faster) on its own thread and renders head cameras on another.

Cameras keep their rate in simulated time, as everything in the world does: a world that falls behind real time
(a loaded machine, a match in lockstep) sees at 10 Hz of its own time, not more often per simulated second; the
physics thread wakes the camera thread when the next camera is due.

Work that must see the world between steps (a referee's checks) runs on the physics thread every so many simulated
seconds (``every``): a float comparison per chunk of steps, never Python per physics step.
"""

from __future__ import annotations

import logging
import math
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np

from robot_nodes.sim.perception import DetectionNoise, GroundTruthVision, Observation, observe_all
from robot_nodes.sim.world import RobotHandle, SimWorld
from robot_nodes.sim.world_clock import SlowestTicks

log = logging.getLogger(__name__)

MAX_LAG = 0.25  # s of wall time; further behind, the runner stops trying to catch up (and counts it)
# MuJoCo's binding releases the GIL in every mj_step and must take it back after: with Python's default switch
# interval (5 ms), any busy Python thread of the process (perception, the nodes' messages) held each step up to 5 ms.
# 0.2 ms lets physics back in at once and costs a busy thread about 1 % (measured with 8 robots: 500 steps
# beside a spinning thread took 2.67 s at 5 ms, 0.22 s at 0.2 ms, 0.08 s alone). Not for a world in lockstep
# (``start(short_switch=False)``): it waits for its robots each tick anyway, and the forced switches cost more than
# they save (a 4 v 4 match, 60 s of play, twice each: real-time factor mean 0.976/0.985, min 0.839/0.778 at 0.2 ms;
# 0.998/1.000, min 0.923/0.944 at 5 ms; the world 64.5 against 62.5 % of a core).
GIL_SWITCH_INTERVAL_S = 0.0002
BATCH_S = 0.01  # s: a camera due this soon is served with the one that is due now, from the same world state


@dataclass
class CameraFrame:
    """One camera tick of one robot: its perception and, if someone wants it, the rendered image."""

    robot: RobotHandle
    observation: Observation
    image: np.ndarray | None  # (h, w, 3) uint8 RGB
    stamp: float  # wall clock (time.time()) when the world state was taken
    sim_stamp: float  # the world's simulated time of that state, s
    width: int
    height: int


@dataclass
class _Periodic:
    period: float  # simulated seconds
    work: Callable[[], None]
    due: float


class CameraClient:
    """A robot's camera subscription; change rate, size or noise through this handle."""

    def __init__(self, runner: SimRunner, robot: RobotHandle, width: int, height: int, rate_hz: float,
                 on_frame: Callable[[CameraFrame], None], want_image: Callable[[], bool],
                 noise: DetectionNoise | None) -> None:
        self.robot = robot
        self.width = width
        self.height = height
        self.rate_hz = rate_hz
        self.on_frame = on_frame
        self.want_image = want_image
        self.vision = GroundTruthVision(runner.world, robot, width, height, noise)
        self.next_due = runner.world.time  # simulated seconds: the first frame at once
        self.frames = 0
        self.errors = 0

    def resize(self, width: int, height: int) -> None:
        self.width, self.height = width, height
        self.vision.resize(width, height)


class SimRunner:
    """Physics on one thread at ``real_time_factor`` x real time (0: as fast as possible), cameras on another.

    Both hold ``world.lock`` only while they touch the live MjData; cameras render from a snapshot.
    """

    def __init__(self, world: SimWorld, real_time_factor: float = 1.0, chunk: float = 0.004) -> None:
        self.world = world
        self.real_time_factor = real_time_factor
        self.chunk_steps = max(1, round(chunk / world.timestep))
        self.lag_resets = 0
        self._stop = threading.Event()
        self._clients: list[CameraClient] = []
        self._clients_lock = threading.Lock()
        self._physics: threading.Thread | None = None
        self._cameras: threading.Thread | None = None
        self._snapshot = mujoco.MjData(world.model)
        self.render_error: str = ""
        self._periodic: list[_Periodic] = []
        self.periodic_errors = 0
        self._clock_period = 0.0
        self._clock_due: float | None = None  # simulated time of the next clock tick (tick_clock)
        self._clock_tick: Callable[[float], None] | None = None
        self.clock_errors = 0
        # in lockstep, the clock's record of its slowest tick per second (WorldClock.slowest; set by who ticks it)
        self.slowest_ticks: SlowestTicks | None = None
        self._camera_wake = math.inf  # simulated time at which the physics thread wakes the camera thread
        self._camera_event = threading.Event()

    # -- control -----------------------------------------------------------------------------------------
    def start(self, short_switch: bool = True) -> SimRunner:
        """Starts both threads; short_switch: shortens the process's GIL switch interval for the physics
        (GIL_SWITCH_INTERVAL_S)."""
        if short_switch:
            sys.setswitchinterval(min(sys.getswitchinterval(), GIL_SWITCH_INTERVAL_S))
        self._physics = threading.Thread(target=self._run_physics, name="sim-physics", daemon=True)
        self._cameras = threading.Thread(target=self._run_cameras, name="sim-cameras", daemon=True)
        self._physics.start()
        self._cameras.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._camera_event.set()
        for t in (self._physics, self._cameras):
            if t is not None and t is not threading.current_thread():
                t.join(5.0)

    def set_real_time_factor(self, factor: float) -> None:
        self.real_time_factor = max(0.0, factor)
        self._rebase = True

    def every(self, seconds: float, work: Callable[[], None]) -> None:
        """Runs ``work`` on the physics thread, holding the world's lock, every ``seconds`` of simulated time
        (not faster than the runner's chunk of steps). A failing call is logged and counted, never stops physics."""
        if seconds <= 0:
            raise ValueError(f"period must be > 0 s, got {seconds}")
        self._periodic.append(_Periodic(seconds, work, self.world.time + seconds))

    def tick_clock(self, period_s: float, tick: Callable[[float], None]) -> None:
        """Calls ``tick(simulated seconds)`` on the physics thread, without the world's lock, each time simulated
        time reaches a multiple of ``period_s``; the runner steps to those times exactly. This is the simulated clock
        the robots' nodes follow (robot_nodes/runtime/clock.py)."""
        if period_s <= 0:
            raise ValueError(f"period_s must be > 0 s, got {period_s}")
        self._clock_period, self._clock_tick = period_s, tick
        self._clock_due = (math.floor(self.world.time / period_s + 1e-6) + 1) * period_s

    def add_camera(self, robot: RobotHandle, on_frame: Callable[[CameraFrame], None], width: int = 320,
                   height: int = 240, rate_hz: float = 10.0, want_image: Callable[[], bool] = lambda: True,
                   noise: DetectionNoise | None = None) -> CameraClient:
        """on_frame runs on the camera thread: keep it short, hand work to your own loop."""
        client = CameraClient(self, robot, width, height, rate_hz, on_frame, want_image, noise)
        with self._clients_lock:
            self._clients.append(client)
        return client

    def remove_camera(self, client: CameraClient) -> None:
        with self._clients_lock:
            if client in self._clients:
                self._clients.remove(client)

    # -- threads -----------------------------------------------------------------------------------------
    _rebase = True

    def _run_physics(self) -> None:
        world = self.world
        wall0 = sim0 = 0.0
        while not self._stop.is_set():
            if self._rebase:
                wall0, sim0, self._rebase = time.monotonic(), world.time, False
            steps, clock_due = self.chunk_steps, self._clock_due
            with world.lock:
                if clock_due is not None:  # a chunk ends on the clock's next tick
                    steps = max(1, min(steps, math.ceil((clock_due - world.time) / world.timestep - 1e-6)))
                world.step(steps)
                sim_now = world.time
                for job in self._periodic:
                    if sim_now >= job.due:
                        job.due = max(job.due + job.period, sim_now)
                        self._run_periodic(job)
            if sim_now >= self._camera_wake:
                self._camera_wake = math.inf
                self._camera_event.set()
            if clock_due is not None and sim_now >= clock_due - 1e-9:
                self._tick_clock(clock_due, sim_now)
            factor = self.real_time_factor
            if factor <= 0:
                time.sleep(0)  # let the node threads in
                continue
            due = wall0 + (sim_now - sim0) / factor
            ahead = due - time.monotonic()
            if ahead > 0:
                self._stop.wait(ahead)
            elif ahead < -MAX_LAG:
                self.lag_resets += 1
                self._rebase = True

    def _tick_clock(self, due: float, sim_now: float) -> None:
        period = self._clock_period
        self._clock_due = due + period * max(1, math.floor((sim_now - due) / period + 1e-6) + 1)
        try:
            self._clock_tick(due if sim_now - due < 1e-6 else sim_now)  # type: ignore[misc]
        except Exception:  # a clock that cannot be sent (the session closing) must not stop the world
            self.clock_errors += 1
            if self.clock_errors in (1, 100) or self.clock_errors % 10000 == 0:
                log.exception("the simulated clock's tick failed (%d times)", self.clock_errors)

    def _run_periodic(self, job: _Periodic) -> None:
        try:
            job.work()
        except Exception:  # one failing check must not stop the world
            self.periodic_errors += 1
            log.exception("periodic work on the physics thread failed")

    def _run_cameras(self) -> None:
        from robot_nodes.sim.camera import HeadCamera, RenderError

        cameras: dict[tuple[int, int, int], HeadCamera] = {}
        world = self.world
        while not self._stop.is_set():
            with self._clients_lock:
                clients = list(self._clients)
            now = world.time
            # cameras tick on a common grid (multiples of their period, simulated seconds): those due within
            # BATCH_S share one copy of the world, one mj_copyData per pass rather than one per robot
            due = [c for c in clients if c.next_due <= now + BATCH_S]
            if not due or min(c.next_due for c in due) > now:
                # clear, say when, look again: a step that passed the time meanwhile is not missed
                self._camera_event.clear()
                self._camera_wake = min((c.next_due for c in clients), default=math.inf)
                if world.time < self._camera_wake:
                    self._camera_event.wait(0.05)  # at the latest: new cameras, stop
                continue
            with world.lock:
                mujoco.mj_copyData(self._snapshot, world.model, world.data)
                stamp, sim_stamp = time.time(), float(self._snapshot.time)
            for client in due:
                served_for = max(now, client.next_due) * client.rate_hz  # in periods (served early: its own due)
                client.next_due = (math.floor(served_for + 1e-6) + 1) / client.rate_hz
            try:  # every robot's view at once (observe_all: numpy's cost is per call)
                observations = observe_all([client.vision for client in due], self._snapshot)
            except Exception:  # a bad world state must not end the camera thread
                for client in due:
                    client.errors += 1
                log.exception("perception of %s failed", ", ".join(client.robot.robot_id for client in due))
                continue
            for client, obs in zip(due, observations, strict=True):
                try:
                    image = None
                    if client.want_image() and not self.render_error:
                        key = (client.robot.index, client.width, client.height)
                        if key not in cameras:
                            cameras[key] = HeadCamera(world, client.robot, client.width, client.height)
                        image = cameras[key].render(self._snapshot)
                    client.frames += 1
                    client.on_frame(CameraFrame(client.robot, obs, image, stamp, sim_stamp, client.width,
                                                client.height))
                except RenderError as exc:
                    self.render_error = str(exc)
                    log.error("camera rendering off: %s", exc)
                except Exception:  # one bad frame must not end the camera thread
                    client.errors += 1
                    log.exception("camera frame of %s failed", client.robot.robot_id)
        for cam in cameras.values():
            cam.close()
