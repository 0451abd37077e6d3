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
POST_RAYS = 5  # points up a goal post tested for occlusion: a post partly hidden is still seen


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
        lines = line_segments(f)
        self._n_lines = len(lines)
        self._posts = goal_posts(f)
        self._ball_geom = world.model.geom("ball").id
        self._post_geoms = [world.model.geom(f"goal_post{i}").id for i in range(4)]
        self._rays = np.array([1, 1, 0, 1, 1, 1], dtype=np.uint8)
        self._rays[GROUP_LINES] = 0
        self._lost_until = -math.inf  # simulated time until which the localization is lost
        # goal posts (0-3) and crossbars (4: the +x goal's, 5: the -x goal's) as segments, clipped together
        top_z = f.goal_height + f.post_diameter
        bar_z = top_z - f.post_diameter / 2
        posts = np.asarray(self._posts, dtype=float)
        feet = np.column_stack([posts, np.zeros(4)])
        tops = np.column_stack([posts, np.full(4, top_z)])
        # every segment the camera may see, clipped at once: the field lines, then the goal's parts
        self._segment_ends = tuple(
            np.vstack([np.column_stack([lines[:, end], np.zeros(len(lines))]), goal_end])
            for end, goal_end in ((0, np.vstack([feet, [*posts[0], bar_z], [*posts[2], bar_z]])),
                                  (1, np.vstack([tops, [*posts[1], bar_z], [*posts[3], bar_z]]))))
        heights = np.linspace(0.1, top_z - 0.05, POST_RAYS)
        self._post_points = np.array([[[px, py, h] for h in heights] for px, py in posts])
        self._others = [o for o in world.robots if o is not robot]
        self._other_bodies = np.array([o.base_body for o in self._others], dtype=int)
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

    def _segments_in_image(self, d: mujoco.MjData, ends_a: np.ndarray, ends_b: np.ndarray
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """World segments a-b (n, 3) in pixels, clipped to the near plane and the image, all at once with numpy (it
        runs for every robot at the camera rate): the ends (m, 2), their depths (m,) and which segments (m,)."""
        n = len(ends_a)
        opt = self.to_optical(d, np.vstack([ends_a, ends_b]))
        oa, ob = opt[:n], opt[n:]
        za, zb = oa[:, 2], ob[:, 2]
        front = (za >= NEAR) | (zb >= NEAR)
        # clip to the near plane: the end behind it moves along the segment onto the plane
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(za != zb, (NEAR - za) / (zb - za), 0.0)
        cut = oa + t[:, None] * (ob - oa)
        oa = np.where((za < NEAR)[:, None], cut, oa)
        ob = np.where((zb < NEAR)[:, None], cut, ob)
        index = np.nonzero(front)[0]
        oa, ob = oa[index], ob[index]
        pa, pb = self.project(oa), self.project(ob)
        k = self.intrinsics
        t0, t1 = _liang_barsky_many(pa, pb, float(k.width), float(k.height))
        inside = t0 <= t1
        pa, pb, oa, ob, t0, t1, index = (pa[inside], pb[inside], oa[inside], ob[inside], t0[inside], t1[inside],
                                         index[inside])
        return (pa + t0[:, None] * (pb - pa), pa + t1[:, None] * (pb - pa),
                oa[:, 2] + t0 * (ob[:, 2] - oa[:, 2]), oa[:, 2] + t1 * (ob[:, 2] - oa[:, 2]), index)

    def _clear(self, d: mujoco.MjData, targets: np.ndarray) -> np.ndarray:
        """Rays from the lens to each target (n, 3), in one MuJoCo call: per target (distance along the ray to the
        first thing hit or -1, the target's distance, the geom hit)."""
        start = d.cam_xpos[self.robot.camera_id].copy()
        vecs = targets - start
        dists = np.linalg.norm(vecs, axis=1)
        n = len(targets)
        hit = np.full(n, -1, dtype=np.int32)
        along = np.full(n, -1.0)
        mujoco.mj_multiRay(self.world.model, d, start, (vecs / dists[:, None]).ravel(), self._rays, 1,
                           self.robot.head_body, hit, along, None, n, mujoco.mjMAXVAL)
        return np.column_stack([along, dists, hit])

    @staticmethod
    def _seen(ray: np.ndarray, geoms: set[int], distance_slack: float) -> bool:
        """A ray of _clear reached its target: nothing hit, nothing before it, or one of its ``geoms``."""
        along, dist, hit = ray
        return bool(along < 0 or along >= dist - distance_slack or int(hit) in geoms)

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

        # where rays must go (ball, and five points up each goal post in the image): one batch of rays for all
        ball = d.xpos[self.world.model.geom_bodyid[self._ball_geom]].copy()
        ob = self.to_optical(d, ball)[0]
        dist = float(np.linalg.norm(ob))
        ball_uv = self.project(ob) if ob[2] > NEAR and dist <= noise.max_distance else None
        if ball_uv is not None and not self._in_image(ball_uv):
            ball_uv = None
        a, b, z0, z1, index = self._segments_in_image(d, *self._segment_ends)
        is_line = index < self._n_lines
        lines = (a[is_line], b[is_line], z0[is_line], z1[is_line])
        goal_parts = (a[~is_line], b[~is_line], z0[~is_line], z1[~is_line], index[~is_line] - self._n_lines)
        posts_in_image = [(int(i), a, b, z0, z1) for a, b, z0, z1, i in zip(*goal_parts, strict=True) if i < 4]
        targets = [ball] if ball_uv is not None else []
        for i, *_ in posts_in_image:
            targets += [self._post_points[i, j] for j in range(POST_RAYS)]
        clear = self._clear(d, np.array(targets)) if targets else np.zeros((0, 3))

        # ball: in the image, not hidden, not too far, not missed
        if ball_uv is not None and self._seen(clear[0], {self._ball_geom}, f.ball_diameter / 2) and keep():
            radius = f.ball_diameter / 2
            diameter = 2 * k.fx * math.tan(math.asin(min(1.0, radius / dist)))
            uv = ball_uv + rng.normal(0.0, noise.pixel, 2) if noise.pixel > 0 else ball_uv
            obs.ball = BallSeen(float(uv[0]), float(uv[1]), diameter)
            obs.ball_relative = self._noisy(to_rel(ball), dist)
            obs.ball_relative_confidence = 1.0

        # goal posts (a post partly hidden, by a robot in front, is still seen: any of its points will do) and bars
        rays = clear[1:] if ball_uv is not None else clear
        for n, (i, foot, top, z0, z1) in enumerate(posts_in_image):
            hits = rays[n * POST_RAYS:(n + 1) * POST_RAYS]
            if not any(self._seen(hit, {self._post_geoms[i]}, f.post_diameter) for hit in hits):
                continue
            if keep():
                width = float(k.fx * f.post_diameter / max(NEAR, (z0 + z1) / 2))
                obs.posts.append(PostSeen((float(foot[0]), float(foot[1])), (float(top[0]), float(top[1])), width,
                                          i))
        for a, b, z0, z1, i in zip(*goal_parts, strict=True):
            if i >= 4 and keep():
                obs.bars.append(((float(a[0]), float(a[1])), (float(b[0]), float(b[1])),
                                 float(k.fx * f.post_diameter / max(NEAR, (z0 + z1) / 2))))

        # other robots as obstacles: those whose box is in the image and not too far
        self._obstacles(d, obs, to_rel, keep)

        # field lines
        obs.lines = self._lines(*lines)

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

    def _obstacles(self, d: mujoco.MjData, obs: Observation, to_rel: Callable[[np.ndarray], np.ndarray],
                   keep: Callable[[], bool]) -> None:
        """The other robots whose boxes are in the image and not too far, all boxes projected at once."""
        if not self._others:
            return
        k = self.intrinsics
        boxes = self._robot_boxes(d)  # (n, 8, 3)
        opt = self.to_optical(d, boxes.reshape(-1, 3)).reshape(boxes.shape)
        in_front = np.all(opt[:, :, 2] >= NEAR, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = self.project(opt)  # (n, 8, 2)
        size = np.array([k.width, k.height])
        low = np.clip(uv.min(axis=1), 0, size)
        high = np.clip(uv.max(axis=1), 0, size)
        centres = d.xpos[self._other_bodies]
        distance = np.hypot(*(centres[:, :2] - d.cam_xpos[self.robot.camera_id][:2]).T)
        shown = in_front & np.all(high - low >= 1, axis=1) & (distance <= self.noise.max_distance)
        for i in np.nonzero(shown)[0]:
            if keep():
                number = self._others[i].index + 1
                (u0, v0), (u1, v1) = low[i].tolist(), high[i].tolist()
                obs.obstacles.append(ObstacleSeen(number, u0, v0, u1 - u0, v1 - v0))
                obs.obstacles_relative.append((number, self._noisy(to_rel(centres[i].copy()), float(distance[i]))))

    def _lines(self, a: np.ndarray, b: np.ndarray, z0: np.ndarray, z1: np.ndarray
               ) -> list[tuple[tuple[float, float], tuple[float, float], float, float]]:
        """The field lines in the image (clipped ends a, b and their depths) at least a pixel long, with their widths
        in pixels at both ends; less those a false negative drops."""
        long_enough = np.hypot(*(b - a).T) >= 1.0
        width = self.world.field.line_width * self.intrinsics.fx
        rows = np.column_stack([a, b, width / np.maximum(NEAR, z0), width / np.maximum(NEAR, z1)])[long_enough]
        if self.noise.dropout > 0 and len(rows):
            rows = rows[self.rng.random(len(rows)) >= self.noise.dropout]
        return [((ua, va), (ub, vb), wa, wb) for ua, va, ub, vb, wa, wb in rows.tolist()]

    # -- helpers -------------------------------------------------------------------------------------------
    def _pose2d(self, d: mujoco.MjData) -> tuple[float, float, float]:
        b = self.robot.base_body
        xmat = d.xmat[b].reshape(3, 3)
        return float(d.xpos[b, 0]), float(d.xpos[b, 1]), math.atan2(xmat[1, 0], xmat[0, 0])

    def _robot_boxes(self, d: mujoco.MjData) -> np.ndarray:
        """The other robots' boxes (n, 8, 3): footprint turned with each robot's yaw, as high as it stands."""
        bodies = self._other_bodies
        xmat = d.xmat[bodies]  # (n, 9)
        yaw = np.arctan2(xmat[:, 3], xmat[:, 0])
        c, s = np.cos(yaw), np.sin(yaw)
        hx, hy = ROBOT_HALF_SIZE
        dx = np.array([-hx, -hx, -hx, -hx, hx, hx, hx, hx])
        dy = np.array([-hy, -hy, hy, hy, -hy, -hy, hy, hy])
        top = np.maximum(np.minimum(ROBOT_HEIGHT, d.xpos[bodies, 2] + 0.33), 0.15)
        boxes = np.empty((len(bodies), 8, 3))
        boxes[:, :, 0] = d.xpos[bodies, 0][:, None] + c[:, None] * dx - s[:, None] * dy
        boxes[:, :, 1] = d.xpos[bodies, 1][:, None] + s[:, None] * dx + c[:, None] * dy
        boxes[:, :, 2] = np.where(np.arange(8) % 2 == 0, 0.0, top[:, None])
        return boxes

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


def _liang_barsky_many(a: np.ndarray, b: np.ndarray, width: float, height: float) -> tuple[np.ndarray, np.ndarray]:
    """Parameters (t0, t1) of the part of each segment a->b (n, 2) inside [0, width] x [0, height] (Liang-Barsky,
    the four edges at once): t0 > t1 where none is."""
    d = b - a
    p = np.stack([-d[:, 0], d[:, 0], -d[:, 1], d[:, 1]])  # (4, n): one row per edge
    q = np.stack([a[:, 0], width - a[:, 0], a[:, 1], height - a[:, 1]])
    parallel = np.abs(p) < 1e-12
    with np.errstate(divide="ignore", invalid="ignore"):
        t = q / np.where(parallel, 1.0, p)
    t0 = np.max(np.where(~parallel & (p < 0), t, 0.0), axis=0)
    t1 = np.min(np.where(~parallel & (p > 0), t, 1.0), axis=0)
    return t0, np.where(np.any(parallel & (q < 0), axis=0), -1.0, t1)
