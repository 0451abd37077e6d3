"""Ground-truth "vision": what a robot's head camera sees, projected into the image, plus relative positions.

Stands in for a vision and a localization node in simulation: the ball, goal posts, other robots and
field lines are projected with the same pinhole model MuJoCo renders with, so markers drawn from these
detections land on the rendered image. Occlusion is tested with rays for the ball and the posts;
field lines and obstacles are reported without occlusion tests.
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
    """Noise and drop-out of the simulated detections (all zero: exact ground truth)."""

    pixel: float = 0.0  # px, std dev on image coordinates
    relative: float = 0.0  # m, std dev on relative positions
    position: float = 0.0  # m, std dev on the own field position
    yaw: float = 0.0  # rad, std dev on the own heading
    dropout: float = 0.0  # probability that one detection is missed


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
    ball_relative: np.ndarray | None = None  # base_footprint frame (x forward, y left, z up), m
    ball_relative_confidence: float = 0.0
    goal_relative: tuple[np.ndarray, np.ndarray] | None = None  # (left post, right post)
    goal_relative_confidence: float = 0.0
    obstacles_relative: list[tuple[int, np.ndarray]] = field(default_factory=list)
    position: tuple[float, float, float] | None = None  # x, y, yaw on the field


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

        # ball
        ball = d.xpos[self.world.model.geom_bodyid[self._ball_geom]].copy()
        ob = self.to_optical(d, ball)[0]
        if ob[2] > NEAR:
            uv = self.project(ob)
            if self._in_image(uv) and self._visible(d, ball, {self._ball_geom}, f.ball_diameter / 2) and keep():
                radius = f.ball_diameter / 2
                dist = float(np.linalg.norm(ob))
                diameter = 2 * k.fx * math.tan(math.asin(min(1.0, radius / dist)))
                uv = uv + rng.normal(0.0, noise.pixel, 2) if noise.pixel > 0 else uv
                obs.ball = BallSeen(float(uv[0]), float(uv[1]), diameter)

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
                obs.posts.append(PostSeen((float(foot[0]), float(foot[1])), (float(top[0]), float(top[1])), width))
        for left, right in ((0, 1), (2, 3)):
            a = np.array([*self._posts[left], top_z - f.post_diameter / 2])
            b = np.array([*self._posts[right], top_z - f.post_diameter / 2])
            seg = self._clip_segment(d, a, b)
            if seg is not None and keep():
                pa, pb, z0, z1 = seg
                obs.bars.append(((float(pa[0]), float(pa[1])), (float(pb[0]), float(pb[1])),
                                 float(k.fx * f.post_diameter / max(NEAR, (z0 + z1) / 2))))

        # other robots as obstacles
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
            if u1 - u0 >= 1 and v1 - v0 >= 1 and keep():
                obs.obstacles.append(ObstacleSeen(other.index + 1, float(u0), float(v0), float(u1 - u0),
                                                  float(v1 - v0)))

        # field lines
        for (x0, y0), (x1, y1) in self._lines:
            seg = self._clip_segment(d, np.array([x0, y0, 0.0]), np.array([x1, y1, 0.0]))
            if seg is None:
                continue
            pa, pb, z0, z1 = seg
            if np.hypot(*(pb - pa)) < 1.0 or not keep():
                continue
            obs.lines.append(((float(pa[0]), float(pa[1])), (float(pb[0]), float(pb[1])),
                              float(k.fx * f.line_width / max(NEAR, z0)), float(k.fx * f.line_width / max(NEAR, z1))))

        # relative positions (base_footprint frame) and the own position
        x, y, yaw = self._pose2d(d)
        to_rel = _footprint_transform(x, y, yaw)
        if keep():
            obs.ball_relative = self._noisy(to_rel(ball))
            obs.ball_relative_confidence = 1.0 if obs.ball is not None else 0.3
        goals = [(self._posts[0], self._posts[1]), (self._posts[2], self._posts[3])]

        def bearing(goal: tuple[np.ndarray, np.ndarray]) -> float:
            centre = to_rel(np.array([*(goal[0] + goal[1]) / 2, 0.0]))
            return abs(math.atan2(centre[1], centre[0]))

        best = min(goals, key=bearing)  # the goal the robot faces
        if keep():
            one = self._noisy(to_rel(np.array([*best[0], 0.0])))
            two = self._noisy(to_rel(np.array([*best[1], 0.0])))
            one_is_left = math.atan2(one[1], one[0]) >= math.atan2(two[1], two[0])
            left_post, right_post = (one, two) if one_is_left else (two, one)
            obs.goal_relative = (left_post, right_post)
            obs.goal_relative_confidence = 1.0 if obs.posts else 0.3
        for other in self.world.robots:
            if other is not self.robot and keep():
                obs.obstacles_relative.append((other.index + 1, self._noisy(to_rel(d.xpos[other.base_body].copy()))))
        if keep():
            obs.position = (x + rng.normal(0.0, noise.position) if noise.position else x,
                            y + rng.normal(0.0, noise.position) if noise.position else y,
                            _wrap(yaw + rng.normal(0.0, noise.yaw)) if noise.yaw else yaw)
        return obs

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

    def _noisy(self, p: np.ndarray) -> np.ndarray:
        if self.noise.relative > 0:
            p = p.copy()
            p[:2] += self.rng.normal(0.0, self.noise.relative, 2)
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
