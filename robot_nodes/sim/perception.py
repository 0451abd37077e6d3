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
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import mujoco
import numpy as np

from robot_nodes.sim.field import goal_posts, line_segments
from robot_nodes.sim.scene import GROUP_LINES
from robot_nodes.sim.world import RobotHandle, SimWorld

NEAR = 0.05  # m, nothing closer to the lens is seen
ROBOT_HALF_SIZE = (0.08, 0.14)  # m, footprint half extents of a Minibot for obstacle boxes
ROBOT_HEIGHT = 0.70
POST_RAYS = 5  # points up a goal post tested for occlusion: a post partly hidden is still seen
_LINE_COLUMNS = [0, 1, 2, 3, 6, 7]  # in observe_all's table of segments: a line's ends and widths
_OPTICAL = np.array([1.0, -1.0, -1.0])  # MuJoCo's camera frame (x right, y up, z back) to the optical frame


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
        self._last_observed: float | None = None

    def resize(self, width: int, height: int) -> None:
        self.intrinsics = Intrinsics.from_fovy(width, height, float(self.world.model.cam_fovy[self.robot.camera_id]))

    # -- geometry ------------------------------------------------------------------------------------------
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
    def _seen(ray: list[float], geoms: set[int], distance_slack: float) -> bool:
        """A ray of _clear reached its target: nothing hit, nothing before it, or one of its ``geoms``."""
        along, dist, hit = ray
        return bool(along < 0 or along >= dist - distance_slack or int(hit) in geoms)

    # -- the observation ---------------------------------------------------------------------------------
    def observe(self, d: mujoco.MjData | None = None) -> Observation:
        """What the robot perceives in data ``d`` (default: the world's live data; hold world.lock)."""
        return observe_all([self], d)[0]

    def _observe(self, d: mujoco.MjData, view: _View) -> Observation:
        """The observation from this robot's part of the views all robots' cameras had at once (observe_all): the
        rays for occlusion, the losses and the noise, each robot's random draws in a fixed order."""
        noise, rng = self.noise, self.rng
        obs = Observation(stamp_sim=float(d.time))
        keep = (lambda: rng.random() >= noise.dropout) if noise.dropout > 0 else (lambda: True)
        k = self.intrinsics
        f = self.world.field
        x, y, yaw = self._pose2d(d)
        to_rel = _footprint_transform(x, y, yaw)

        # where rays must go (ball, and five points up each goal post in the image): one batch of rays for all
        ball, ball_uv, dist = view.ball, view.ball_uv, view.ball_distance
        posts_in_image = [part for part in view.goal_parts if part[-1] < 4]  # the posts, not the bars
        targets = [ball] if ball_uv is not None else []
        for *_, i in posts_in_image:
            targets.extend(self._post_points[i])
        clear = self._clear(d, np.array(targets)).tolist() if targets else []

        # ball: in the image, not hidden, not too far, not missed
        if ball_uv is not None and self._seen(clear[0], {self._ball_geom}, f.ball_diameter / 2) and keep():
            radius = f.ball_diameter / 2
            diameter = 2 * k.fx * math.tan(math.asin(min(1.0, radius / dist)))
            uv = np.array(ball_uv) + rng.normal(0.0, noise.pixel, 2) if noise.pixel > 0 else ball_uv
            obs.ball = BallSeen(float(uv[0]), float(uv[1]), diameter)
            obs.ball_relative = self._noisy(to_rel(ball), dist)
            obs.ball_relative_confidence = 1.0

        # goal posts (a post partly hidden, by a robot in front, is still seen: any of its points will do) and bars
        rays = clear[1:] if ball_uv is not None else clear
        for n, (ua, va, ub, vb, z0, z1, i) in enumerate(posts_in_image):
            hits = rays[n * POST_RAYS:(n + 1) * POST_RAYS]
            if not any(self._seen(hit, {self._post_geoms[i]}, f.post_diameter) for hit in hits):
                continue
            if keep():
                width = float(k.fx * f.post_diameter / max(NEAR, (z0 + z1) / 2))
                obs.posts.append(PostSeen((ua, va), (ub, vb), width, i))
        for ua, va, ub, vb, z0, z1, i in view.goal_parts:
            if i >= 4 and keep():
                obs.bars.append(((ua, va), (ub, vb), float(k.fx * f.post_diameter / max(NEAR, (z0 + z1) / 2))))

        # other robots as obstacles: those whose box is in the image and not too far
        for j, u0, v0, u1, v1, distance in view.robots:
            if keep():
                number = self.world.robots[j].index + 1
                obs.obstacles.append(ObstacleSeen(number, u0, v0, u1 - u0, v1 - v0))
                centre = d.xpos[self.world.robots[j].base_body].copy()
                obs.obstacles_relative.append((number, self._noisy(to_rel(centre), distance)))

        # field lines at least a pixel long, less those a false negative drops
        lines = view.lines
        if noise.dropout > 0 and lines:
            dropped = rng.random(len(lines)) < noise.dropout
            lines = [line for line, lost in zip(lines, dropped.tolist(), strict=True) if not lost]
        obs.lines = [((ua, va), (ub, vb), wa, wb) for ua, va, ub, vb, wa, wb in lines]

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

    # -- helpers -------------------------------------------------------------------------------------------
    def _pose2d(self, d: mujoco.MjData) -> tuple[float, float, float]:
        b = self.robot.base_body
        xmat = d.xmat[b].reshape(3, 3)
        return float(d.xpos[b, 0]), float(d.xpos[b, 1]), math.atan2(xmat[1, 0], xmat[0, 0])

    def _noisy(self, p: np.ndarray, distance: float) -> np.ndarray:
        """x and y with Gaussian noise whose sigma grows with the distance from the lens."""
        sigma = self.noise.relative_sigma(distance)
        if sigma > 0:
            p = p.copy()
            p[:2] += self.rng.normal(0.0, sigma, 2)
        return p


@dataclass
class _View:
    """One robot's part of what all cameras saw at once (observe_all), before occlusion, losses and noise."""

    ball: np.ndarray  # the ball's centre in the world
    ball_uv: tuple[float, float] | None  # in the image, in front, not too far; else None
    ball_distance: float  # from the lens, m
    goal_parts: list[tuple[float, float, float, float, float, float, int]]  # ends (u, v) x 2, depths, part 0-5
    lines: list[tuple[float, float, float, float, float, float]]  # ends (u, v) x 2, widths (px) at both ends
    robots: list[tuple[int, float, float, float, float, float]]  # world index, box (u0, v0, u1, v1), distance


def observe_all(visions: Sequence[GroundTruthVision], d: mujoco.MjData | None = None) -> list[Observation]:
    """What each robot perceives in data ``d`` (default: the world's live data; hold world.lock).

    The projections and clipping run for all robots at once: with numpy the cost is per call, not per number, and
    the world asks for every robot's view ten times a simulated second (8 robots with the cm730 node's noise: 0.64 ms
    per robot against 1.08 ms for each alone)."""
    if not visions:
        return []
    world = visions[0].world
    if any(v.world is not world for v in visions):
        raise ValueError("observe_all takes robots of one world")
    d = d if d is not None else world.data
    n = len(visions)
    cams = [v.robot.camera_id for v in visions]
    lens, rot = d.cam_xpos[cams], d.cam_xmat[cams].reshape(n, 3, 3)
    # per robot: fx, fy, cx, cy, width, height, max_distance
    k = np.array([(v.intrinsics.fx, v.intrinsics.fy, v.intrinsics.cx, v.intrinsics.cy, v.intrinsics.width,
                   v.intrinsics.height, v.noise.max_distance) for v in visions])

    def optical(points: np.ndarray) -> np.ndarray:
        """World points (p, 3) in each robot's optical frame (x right, y down, z forward): (n, p, 3)."""
        return ((points - lens[:, None, :]) @ rot) * _OPTICAL

    def project(opt: np.ndarray, kk: np.ndarray) -> np.ndarray:
        z = opt[..., 2]
        return np.stack([kk[..., 2] + kk[..., 0] * opt[..., 0] / z, kk[..., 3] + kk[..., 1] * opt[..., 1] / z], axis=-1)

    # the ball
    ball = d.xpos[world.model.geom_bodyid[visions[0]._ball_geom]].copy()
    ob = optical(ball[None, :])[:, 0]
    ball_distance = np.linalg.norm(ob, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ball_uv = project(ob, k)
    ball_shown = ((ob[:, 2] > NEAR) & (ball_distance <= k[:, 6]) & (ball_uv[:, 0] >= 0) & (ball_uv[:, 0] <= k[:, 4])
                  & (ball_uv[:, 1] >= 0) & (ball_uv[:, 1] <= k[:, 5]))

    # field lines and goal parts: clipped to the near plane and the image, all robots' at once
    ends_a, ends_b = visions[0]._segment_ends
    segments = len(ends_a)
    oa, ob_ = optical(ends_a).reshape(-1, 3), optical(ends_b).reshape(-1, 3)
    za, zb = oa[:, 2], ob_[:, 2]
    front = (za >= NEAR) | (zb >= NEAR)
    # clip to the near plane: the end behind it moves along the segment onto the plane
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(za != zb, (NEAR - za) / (zb - za), 0.0)
    cut = oa + t[:, None] * (ob_ - oa)
    oa = np.where((za < NEAR)[:, None], cut, oa)
    ob_ = np.where((zb < NEAR)[:, None], cut, ob_)
    rows = np.nonzero(front)[0]
    oa, ob_ = oa[rows], ob_[rows]
    kk = k[rows // segments]
    pa, pb = project(oa, kk), project(ob_, kk)
    t0, t1 = _liang_barsky_many(pa, pb, kk[:, 4], kk[:, 5])
    inside = t0 <= t1
    pa, pb, oa, ob_, t0, t1, rows, kk = (pa[inside], pb[inside], oa[inside], ob_[inside], t0[inside], t1[inside],
                                         rows[inside], kk[inside])
    a, b = pa + t0[:, None] * (pb - pa), pa + t1[:, None] * (pb - pa)
    z0, z1 = oa[:, 2] + t0 * (ob_[:, 2] - oa[:, 2]), oa[:, 2] + t1 * (ob_[:, 2] - oa[:, 2])
    part = rows % segments - visions[0]._n_lines  # < 0: a field line, else the goal part
    width = world.field.line_width * kk[:, 0]
    # a row per segment seen: its ends (u, v) x 2, their depths, widths in pixels, the goal part (< 0: a line)
    table = np.column_stack([a, b, z0, z1, width / np.maximum(NEAR, z0), width / np.maximum(NEAR, z1), part])
    long_enough = np.hypot(*(b - a).T) >= 1.0
    bounds = np.searchsorted(rows // segments, np.arange(n + 1)).tolist()

    # the other robots: their boxes projected into every camera
    bodies = [r.base_body for r in world.robots]
    boxes = _robot_boxes(d, bodies)  # (m, 8, 3)
    opt = optical(boxes.reshape(-1, 3)).reshape(n, *boxes.shape)
    in_front = np.all(opt[..., 2] >= NEAR, axis=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        uv = project(opt, k[:, None, None, :])  # (n, m, 8, 2)
    size = k[:, None, 4:6]
    low, high = np.clip(uv.min(axis=2), 0, size), np.clip(uv.max(axis=2), 0, size)
    distance = np.hypot(*(d.xpos[bodies][None, :, :2] - lens[:, None, :2]).transpose(2, 0, 1))
    shown = in_front & np.all(high - low >= 1, axis=2) & (distance <= k[:, 6:7])
    shown[np.arange(n), [v.robot.index for v in visions]] = False  # not itself
    boxes_seen = np.concatenate([low, high, distance[..., None]], axis=2)

    observations = []
    for r, vision in enumerate(visions):
        lo, hi = bounds[r], bounds[r + 1]
        mine = table[lo:hi]
        is_line = mine[:, 8] < 0
        lines = [tuple(row) for row in mine[is_line & long_enough[lo:hi]][:, _LINE_COLUMNS].tolist()]
        goal_parts = [(ua, va, ub, vb, za_, zb_, int(i)) for ua, va, ub, vb, za_, zb_, _, _, i
                      in mine[~is_line].tolist()]
        seen = np.nonzero(shown[r])[0].tolist()
        robots = [(j, *boxes_seen[r, j].tolist()) for j in seen]
        uv_r = (float(ball_uv[r, 0]), float(ball_uv[r, 1])) if ball_shown[r] else None
        observations.append(vision._observe(d, _View(ball, uv_r, float(ball_distance[r]), goal_parts, lines, robots)))
    return observations


def _robot_boxes(d: mujoco.MjData, bodies: list[int]) -> np.ndarray:
    """The robots' boxes (n, 8, 3): footprint turned with each robot's yaw, as high as it stands."""
    xmat = d.xmat[bodies]  # (n, 9)
    yaw = np.arctan2(xmat[:, 3], xmat[:, 0])
    c, s = np.cos(yaw), np.sin(yaw)
    hx, hy = ROBOT_HALF_SIZE
    dx = np.array([-hx, -hx, -hx, -hx, hx, hx, hx, hx])
    dy = np.array([-hy, -hy, hy, hy, -hy, -hy, hy, hy])
    xpos = d.xpos[bodies]
    top = np.maximum(np.minimum(ROBOT_HEIGHT, xpos[:, 2] + 0.33), 0.15)
    boxes = np.empty((len(bodies), 8, 3))
    boxes[:, :, 0] = xpos[:, 0][:, None] + c[:, None] * dx - s[:, None] * dy
    boxes[:, :, 1] = xpos[:, 1][:, None] + s[:, None] * dx + c[:, None] * dy
    boxes[:, :, 2] = np.where(np.arange(8) % 2 == 0, 0.0, top[:, None])
    return boxes


def _footprint_transform(x: float, y: float, yaw: float) -> Callable[[np.ndarray], np.ndarray]:
    c, s = math.cos(yaw), math.sin(yaw)

    def to_rel(p: np.ndarray) -> np.ndarray:
        dx, dy = p[0] - x, p[1] - y
        return np.array([c * dx + s * dy, -s * dx + c * dy, p[2]])

    return to_rel


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def _liang_barsky_many(a: np.ndarray, b: np.ndarray, width: np.ndarray, height: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Parameters (t0, t1) of the part of each segment a->b (n, 2) inside [0, width] x [0, height] (Liang-Barsky,
    the four edges at once; each segment its own image size): t0 > t1 where none is."""
    d = b - a
    p = np.stack([-d[:, 0], d[:, 0], -d[:, 1], d[:, 1]])  # (4, n): one row per edge
    q = np.stack([a[:, 0], width - a[:, 0], a[:, 1], height - a[:, 1]])
    parallel = np.abs(p) < 1e-12
    with np.errstate(divide="ignore", invalid="ignore"):
        t = q / np.where(parallel, 1.0, p)
    t0 = np.max(np.where(~parallel & (p < 0), t, 0.0), axis=0)
    t1 = np.min(np.where(~parallel & (p > 0), t, 1.0), axis=0)
    return t0, np.where(np.any(parallel & (q < 0), axis=0), -1.0, t1)
