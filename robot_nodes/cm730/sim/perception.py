"""Perception stand-ins: what a robot's head camera could see, from the simulation's ground truth, with stated noise.

Stands in for a vision and a localization node in simulation, and says so: the ball, goal posts, other robots and
field lines are projected with the same pinhole model MuJoCo renders with, so markers drawn from these
detections land on the rendered image. Occlusion is tested with rays for the ball and the posts;
field lines and obstacles are reported without occlusion tests.

Relative positions (ball, goal, obstacles) exist only for what the camera sees: inside the image of the head as its
joints point it, not hidden, not farther than ``max_distance`` (ball and robots), and not lost to a false negative
(``dropout``); their noise grows with distance. The own position is the ground truth with Gaussian noise and
occasional losses of a few seconds, what a decent localization gives. ``DetectionNoise`` holds every number.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import mujoco
import numpy as np

from robot_nodes.cm730.sim.field import goal_posts, line_segments
from robot_nodes.cm730.sim.scene import GROUP_LINES
from robot_nodes.cm730.sim.world import RobotHandle, SimWorld

NEAR = 0.05  # m, nothing closer to the lens is seen
ROBOT_HALF_SIZE = (0.08, 0.14)  # m, footprint half extents of a Minibot for obstacle boxes
ROBOT_HEIGHT = 0.70


@dataclass
class DetectionNoise:
    """Noise, range and losses of the simulated perception (the defaults: exact ground truth of what is in view).

    The cm730 node's parameters set them (robot_nodes/cm730/node.py: its defaults are a decent robot's)."""

    pixel: float = 0.0  # px, std dev on image coordinates
    relative: float = 0.0  # m, std dev (x and y each) of relative positions right in front of the lens
    relative_per_m: float = 0.0  # m of std dev added per metre of distance: a far ball is noisier
    position: float = 0.0  # m, std dev (x and y each) on the own field position
    yaw: float = 0.0  # rad, std dev on the own heading
    dropout: float = 0.0  # probability that one detection is missed (a false negative)
    max_distance: float = math.inf  # m, ball and robots farther away are not seen
    position_losses_per_min: float = 0.0  # how often the localization is lost (a Poisson rate)
    position_loss_s: float = 0.0  # for how long (simulated seconds) it is lost then

    def relative_sigma(self, distance: float) -> float:
        return self.relative + self.relative_per_m * distance


@dataclass(frozen=True, slots=True)
class Intrinsics:
    """Pinhole camera without distortion, pixel centres at integer + 0.5."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    @classmethod
    def from_fovy(cls, width: int, height: int, fovy_deg: float) -> Intrinsics:
        f = (height / 2) / math.tan(math.radians(fovy_deg) / 2)
        return cls(width, height, f, f, width / 2, height / 2)


@dataclass
class BallSeen:
    u: float
    v: float
    diameter: float  # px


@dataclass
class PostSeen:
    foot: tuple[float, float]
    top: tuple[float, float]
    width: float  # px
    index: int = 0  # which post (field.goal_posts order: 0, 1 the +x goal, 2, 3 the -x goal)


@dataclass
class ObstacleSeen:
    player_number: int
    u: float  # top left
    v: float
    width: float
    height: float


@dataclass
class Observation:
    """Everything one robot perceives at one instant; None or empty where nothing is seen or it dropped out."""

    stamp_sim: float
    ball: BallSeen | None = None
    posts: list[PostSeen] = field(default_factory=list)
    bars: list[tuple[tuple[float, float], tuple[float, float], float]] = field(default_factory=list)
    obstacles: list[ObstacleSeen] = field(default_factory=list)
    lines: list[tuple[tuple[float, float], tuple[float, float], float, float]] = field(default_factory=list)
    ball_relative: np.ndarray | None = None  # base_footprint frame (x forward, y left, z up), m; None: not seen
    ball_relative_confidence: float = 0.0
    goal_relative: tuple[np.ndarray, np.ndarray] | None = None  # (left post, right post); None: no post seen
    goal_relative_confidence: float = 0.0
    obstacles_relative: list[tuple[int, np.ndarray]] = field(default_factory=list)  # only robots in view
    position: tuple[float, float, float] | None = None  # x, y, yaw on the field; None: localization lost


class GroundTruthVision:
    """Perception of one robot from the world's state (or from a snapshot MjData of it)."""

    def __init__(self, world: SimWorld, robot: RobotHandle, width: int = 320, height: int = 240,
                 noise: DetectionNoise | None = None, seed: int = 0) -> None:
        self.world = world
        self.robot = robot
        self.noise = noise or DetectionNoise()
        self.rng = np.random.default_rng(seed + 1000 * robot.index)
        self.intrinsics = Intrinsics.from_fovy(width, height, float(world.model.cam_fovy[robot.camera_id]))
        f = world.field
        self._lines = line_segments(f)
        self._posts = goal_posts(f)
        self._ball_geom = world.model.geom("ball").id
        self._post_geoms = [world.model.geom(f"goal_post{i}").id for i in range(4)]
        self._rays = np.array([1, 1, 0, 1, 1, 1], dtype=np.uint8)
        self._rays[GROUP_LINES] = 0
        self._lost_until = -math.inf  # simulated time until which the localization is lost
        self._last_observed: float | None = None

    def resize(self, width: int, height: int) -> None:
        self.intrinsics = Intrinsics.from_fovy(width, height, float(self.world.model.cam_fovy[self.robot.camera_id]))

    # -- geometry ------------------------------------------------------------------------------------------
    def to_optical(self, d: mujoco.MjData, points: np.ndarray) -> np.ndarray:
        """World points (n, 3) in the optical frame (x right, y down, z forward)."""
        cam = self.robot.camera_id
        rot = d.cam_xmat[cam].reshape(3, 3)
        local = (np.atleast_2d(points) - d.cam_xpos[cam]) @ rot
        return local * np.array([1.0, -1.0, -1.0])

    def project(self, optical: np.ndarray) -> np.ndarray:
        k = self.intrinsics
        z = optical[..., 2]
        return np.stack([k.cx + k.fx * optical[..., 0] / z, k.cy + k.fy * optical[..., 1] / z], axis=-1)

    def _in_image(self, uv: np.ndarray) -> bool:
        k = self.intrinsics
        return bool(0 <= uv[0] <= k.width and 0 <= uv[1] <= k.height)

    def _clip_segment(self, d: mujoco.MjData, a: np.ndarray, b: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray, float, float] | None:
        """World segment a-b in pixels, clipped to the near plane and the image; with depths of the ends."""
        oa, ob = self.to_optical(d, np.array([a, b]))
        if oa[2] < NEAR and ob[2] < NEAR:
            return None
        if oa[2] < NEAR or ob[2] < NEAR:
            t = (NEAR - oa[2]) / (ob[2] - oa[2])
            cut = oa + t * (ob - oa)
            oa, ob = (cut, ob) if oa[2] < NEAR else (oa, cut)
        pa, pb = self.project(oa), self.project(ob)
        k = self.intrinsics
        t0, t1 = _liang_barsky(pa, pb, 0.0, 0.0, float(k.width), float(k.height))
        if t0 is None:
            return None
        za, zb = oa[2], ob[2]
        return pa + t0 * (pb - pa), pa + t1 * (pb - pa), za + t0 * (zb - za), za + t1 * (zb - za)

    def _visible(self, d: mujoco.MjData, target: np.ndarray, geoms: set[int] | None, distance_slack: float) -> bool:
        """Nothing but ``geoms`` (or nothing at all) lies between the lens and ``target``."""
        start = d.cam_xpos[self.robot.camera_id].copy()
        vec = target - start
        dist = float(np.linalg.norm(vec))
        hit = np.array([-1], dtype=np.int32)
        along = mujoco.mj_ray(self.world.model, d, start, vec / dist, self._rays, 1, self.robot.head_body, hit)
        return along < 0 or along >= dist - distance_slack or (geoms is not None and int(hit[0]) in geoms)

    # -- the observation ---------------------------------------------------------------------------------
    def observe(self, d: mujoco.MjData | None = None) -> Observation:
        """What the robot perceives in data ``d`` (default: the world's live data; hold world.lock)."""
        d = d if d is not None else self.world.data
        noise, rng = self.noise, self.rng
        obs = Observation(stamp_sim=float(d.time))
        keep = (lambda: rng.random() >= noise.dropout) if noise.dropout > 0 else (lambda: True)
        k = self.intrinsics
        f = self.world.field
        x, y, yaw = self._pose2d(d)
        to_rel = _footprint_transform(x, y, yaw)

        # ball: in the image, not hidden, not too far, not missed
        ball = d.xpos[self.world.model.geom_bodyid[self._ball_geom]].copy()
        ob = self.to_optical(d, ball)[0]
        dist = float(np.linalg.norm(ob))
        if ob[2] > NEAR and dist <= noise.max_distance:
            uv = self.project(ob)
            if self._in_image(uv) and self._visible(d, ball, {self._ball_geom}, f.ball_diameter / 2) and keep():
                radius = f.ball_diameter / 2
                diameter = 2 * k.fx * math.tan(math.asin(min(1.0, radius / dist)))
                uv = uv + rng.normal(0.0, noise.pixel, 2) if noise.pixel > 0 else uv
                obs.ball = BallSeen(float(uv[0]), float(uv[1]), diameter)
                obs.ball_relative = self._noisy(to_rel(ball), dist)
                obs.ball_relative_confidence = 1.0

        # goal posts and crossbars
        top_z = f.goal_height + f.post_diameter
        for i, (px, py) in enumerate(self._posts):
            seg = self._clip_segment(d, np.array([px, py, 0.0]), np.array([px, py, top_z]))
            if seg is None:
                continue
            foot, top, z0, z1 = seg
            # a post partly hidden (by a robot in front) is still seen: any of five points along it will do
            heights = np.linspace(0.1, top_z - 0.05, 5)
            if not any(self._visible(d, np.array([px, py, h]), {self._post_geoms[i]}, f.post_diameter)
                       for h in heights):
                continue
            if keep():
                width = float(k.fx * f.post_diameter / max(NEAR, (z0 + z1) / 2))
                obs.posts.append(PostSeen((float(foot[0]), float(foot[1])), (float(top[0]), float(top[1])), width,
                                          i))
        for left, right in ((0, 1), (2, 3)):
            a = np.array([*self._posts[left], top_z - f.post_diameter / 2])
            b = np.array([*self._posts[right], top_z - f.post_diameter / 2])
            seg = self._clip_segment(d, a, b)
            if seg is not None and keep():
                pa, pb, z0, z1 = seg
                obs.bars.append(((float(pa[0]), float(pa[1])), (float(pb[0]), float(pb[1])),
                                 float(k.fx * f.post_diameter / max(NEAR, (z0 + z1) / 2))))

        # other robots as obstacles: those whose box is in the image and not too far
        for other in self.world.robots:
            if other is self.robot:
                continue
            box = self._robot_box(d, other)
            opt = self.to_optical(d, box)
            if np.any(opt[:, 2] < NEAR):
                continue
            uv = self.project(opt)
            u0, v0 = np.clip(uv.min(axis=0), 0, [k.width, k.height])
            u1, v1 = np.clip(uv.max(axis=0), 0, [k.width, k.height])
            centre = d.xpos[other.base_body].copy()
            distance = float(np.linalg.norm(centre[:2] - d.cam_xpos[self.robot.camera_id][:2]))
            if u1 - u0 >= 1 and v1 - v0 >= 1 and distance <= noise.max_distance and keep():
                obs.obstacles.append(ObstacleSeen(other.index + 1, float(u0), float(v0), float(u1 - u0),
                                                  float(v1 - v0)))
                obs.obstacles_relative.append((other.index + 1, self._noisy(to_rel(centre), distance)))

        # field lines
        obs.lines = self._lines_in_image(d)

        # the goal whose posts are seen (the one with more of them; the nearer if both show as many)
        seen = [p.index for p in obs.posts]
        if seen:
            def distance_to(goal: int) -> float:
                return float(np.hypot(*(self._posts[2 * goal] - (x, y))))

            goal = max((0, 1), key=lambda g: (sum(1 for i in seen if i // 2 == g), -distance_to(g)))
            a, b = self._posts[2 * goal], self._posts[2 * goal + 1]
            one = self._noisy(to_rel(np.array([*a, 0.0])), float(np.hypot(*(a - (x, y)))))
            two = self._noisy(to_rel(np.array([*b, 0.0])), float(np.hypot(*(b - (x, y)))))
            one_is_left = math.atan2(one[1], one[0]) >= math.atan2(two[1], two[0])
            obs.goal_relative = (one, two) if one_is_left else (two, one)
            obs.goal_relative_confidence = 1.0 if sum(1 for i in seen if i // 2 == goal) == 2 else 0.5

        # the own position: ground truth with noise, unless the localization is lost just now
        if not self._position_lost(obs.stamp_sim):
            obs.position = (x + rng.normal(0.0, noise.position) if noise.position else x,
                            y + rng.normal(0.0, noise.position) if noise.position else y,
                            _wrap(yaw + rng.normal(0.0, noise.yaw)) if noise.yaw else yaw)
        return obs

    def _position_lost(self, now: float) -> bool:
        """Losses start at random (a Poisson process in simulated time) and last ``position_loss_s``."""
        noise = self.noise
        dt = max(0.0, now - self._last_observed) if self._last_observed is not None else 0.0
        self._last_observed = now
        if now < self._lost_until:
            return True
        rate = noise.position_losses_per_min / 60.0
        if rate > 0 and noise.position_loss_s > 0 and self.rng.random() < 1.0 - math.exp(-rate * dt):
            self._lost_until = now + noise.position_loss_s
            return True
        return False

    def _lines_in_image(self, d: mujoco.MjData) -> list[tuple[tuple[float, float], tuple[float, float], float, float]]:
        """Every field line segment in the image (clipped), with its width in pixels at both ends: all segments at
        once with numpy, as this runs for every robot at the camera rate."""
        n = len(self._lines)
        ends = np.zeros((2 * n, 3))
        ends[:n, :2] = self._lines[:, 0]
        ends[n:, :2] = self._lines[:, 1]
        opt = self.to_optical(d, ends)
        oa, ob = opt[:n], opt[n:]
        za, zb = oa[:, 2], ob[:, 2]
        front = (za >= NEAR) | (zb >= NEAR)
        # clip to the near plane: the end behind it moves along the segment onto the plane
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(za != zb, (NEAR - za) / (zb - za), 0.0)
        cut = oa + t[:, None] * (ob - oa)
        oa = np.where((za < NEAR)[:, None], cut, oa)
        ob = np.where((zb < NEAR)[:, None], cut, ob)
        oa, ob = oa[front], ob[front]
        if not len(oa):
            return []
        pa, pb = self.project(oa), self.project(ob)
        k = self.intrinsics
        t0, t1 = _liang_barsky_many(pa, pb, float(k.width), float(k.height))
        inside = t0 <= t1
        pa, pb, oa, ob, t0, t1 = pa[inside], pb[inside], oa[inside], ob[inside], t0[inside], t1[inside]
        a = pa + t0[:, None] * (pb - pa)
        b = pa + t1[:, None] * (pb - pa)
        z0 = oa[:, 2] + t0 * (ob[:, 2] - oa[:, 2])
        z1 = oa[:, 2] + t1 * (ob[:, 2] - oa[:, 2])
        long_enough = np.hypot(*(b - a).T) >= 1.0
        width = self.world.field.line_width * k.fx
        out = []
        for i in np.nonzero(long_enough)[0]:
            if self.noise.dropout <= 0 or self.rng.random() >= self.noise.dropout:
                out.append(((float(a[i, 0]), float(a[i, 1])), (float(b[i, 0]), float(b[i, 1])),
                            float(width / max(NEAR, z0[i])), float(width / max(NEAR, z1[i]))))
        return out

    # -- helpers -------------------------------------------------------------------------------------------
    def _pose2d(self, d: mujoco.MjData) -> tuple[float, float, float]:
        b = self.robot.base_body
        xmat = d.xmat[b].reshape(3, 3)
        return float(d.xpos[b, 0]), float(d.xpos[b, 1]), math.atan2(xmat[1, 0], xmat[0, 0])

    def _robot_box(self, d: mujoco.MjData, other: RobotHandle) -> np.ndarray:
        b = other.base_body
        xmat = d.xmat[b].reshape(3, 3)
        yaw = math.atan2(xmat[1, 0], xmat[0, 0])
        c, s = math.cos(yaw), math.sin(yaw)
        hx, hy = ROBOT_HALF_SIZE
        height = min(ROBOT_HEIGHT, float(d.xpos[b, 2]) + 0.33)
        corners = []
        for dx in (-hx, hx):
            for dy in (-hy, hy):
                for z in (0.0, max(height, 0.15)):
                    corners.append((d.xpos[b, 0] + c * dx - s * dy, d.xpos[b, 1] + s * dx + c * dy, z))
        return np.array(corners)

    def _noisy(self, p: np.ndarray, distance: float) -> np.ndarray:
        """x and y with Gaussian noise whose sigma grows with the distance from the lens."""
        sigma = self.noise.relative_sigma(distance)
        if sigma > 0:
            p = p.copy()
            p[:2] += self.rng.normal(0.0, sigma, 2)
        return p


def _footprint_transform(x: float, y: float, yaw: float) -> Callable[[np.ndarray], np.ndarray]:
    c, s = math.cos(yaw), math.sin(yaw)

    def to_rel(p: np.ndarray) -> np.ndarray:
        dx, dy = p[0] - x, p[1] - y
        return np.array([c * dx + s * dy, -s * dx + c * dy, p[2]])

    return to_rel


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def _liang_barsky(a: np.ndarray, b: np.ndarray, xmin: float, ymin: float, xmax: float, ymax: float
                  ) -> tuple[float | None, float]:
    """Parameters (t0, t1) of the part of a->b inside the rectangle, or (None, 0) if none is."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    t0, t1 = 0.0, 1.0
    for p, q in ((-dx, a[0] - xmin), (dx, xmax - a[0]), (-dy, a[1] - ymin), (dy, ymax - a[1])):
        if abs(p) < 1e-12:
            if q < 0:
                return None, 0.0
            continue
        t = q / p
        if p < 0:
            t0 = max(t0, t)
        else:
            t1 = min(t1, t)
        if t0 > t1:
            return None, 0.0
    return t0, t1


def _liang_barsky_many(a: np.ndarray, b: np.ndarray, width: float, height: float) -> tuple[np.ndarray, np.ndarray]:
    """_liang_barsky for many segments a->b (n, 2) against [0, width] x [0, height]: t0 > t1 where none is inside."""
    d = b - a
    t0 = np.zeros(len(a))
    t1 = np.ones(len(a))
    for p, q in ((-d[:, 0], a[:, 0]), (d[:, 0], width - a[:, 0]), (-d[:, 1], a[:, 1]), (d[:, 1], height - a[:, 1])):
        parallel = np.abs(p) < 1e-12
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(parallel, 0.0, q / np.where(parallel, 1.0, p))
        t0 = np.where(~parallel & (p < 0), np.maximum(t0, t), t0)
        t1 = np.where(~parallel & (p > 0), np.minimum(t1, t), t1)
        t1 = np.where(parallel & (q < 0), -1.0, t1)
    return t0, t1
