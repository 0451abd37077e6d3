"""tf from what the robots send: robot_state_publisher's job, done in the server for every robot it hears.

From a robot's URDF (yourdfpy parses it) and its joint_states, each joint's transform parent -> child, as ROS 2's
robot_state_publisher computes it: movable joints on the robot's tf at each joint_states (at most ``max_hz``), fixed
joints once on its tf_static. Above the URDF's root link the robot stands on the field:

    map -> <robot>/odom -> <robot>/base_footprint -> <robot>/<root link> -> ... every link ...

``map`` is the field (centre spot at the origin, x towards the opponent goal): the frame every robot shares. ``map ->
odom`` comes from the robot's ``position`` (its localisation) and ``walk_odometry`` (odom -> base_footprint), as a
localisation node would publish it; without odometry ``odom`` is where the position says the robot is. ``base_footprint
-> root`` lifts the robot so its lower sole touches the ground and tilts it by the IMU's roll and pitch. The
simulation's ground truth is a frame tree of its own beside it: ``map -> <robot>/ground_truth/torso``. Every frame but
``map`` carries the robot id (``robot1/l_sole``), so several robots share one scene; a replayed robot's frames carry its
replay id (``replay.robot1/l_sole``).

Nothing here knows Foxglove: the endpoint (server.foxglove.scene) and the recorder (server.recording) use the same
messages, so a recording shows the robots in 3D too.
"""

from __future__ import annotations

import functools
import logging
import math
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from schemas.codec import message_class
from schemas.stamps import stamp
from server.config import RobotDescription
from server.hub import HubMessage
from wire import keys

log = logging.getLogger(__name__)

TF_TYPE = "tf2_msgs/msg/TFMessage"
DESCRIPTION_TYPE = "std_msgs/msg/String"
MAP_FRAME = "map"
ODOM, FOOTPRINT, GROUND_TRUTH = "odom", "base_footprint", "ground_truth/torso"
TOPICS = frozenset({"joint_states", "imu/data", "position", "walk_odometry", "ground_truth"})
DEFAULT_MAX_HZ = 20.0  # joint_states come at 100-200 Hz; a 3D view needs no more, and a /tf costs ~0.3 ms to encode
MOVABLE = ("revolute", "continuous", "prismatic")

_TFMessage = message_class(TF_TYPE)
_TransformStamped = message_class("geometry_msgs/msg/TransformStamped")
_Transform = message_class("geometry_msgs/msg/Transform")
_Vector3 = message_class("geometry_msgs/msg/Vector3")
_Quaternion = message_class("geometry_msgs/msg/Quaternion")
_Header = message_class("std_msgs/msg/Header")
_String = message_class(DESCRIPTION_TYPE)


class DescriptionError(ValueError):
    """A robot description (URDF) that cannot be read; the text says which and why."""


# -- quaternions (x, y, z, w), Hamilton product --------------------------------------------------------------
def quaternion_of(rotation: np.ndarray) -> np.ndarray:
    """The unit quaternion (x, y, z, w) of a 3x3 rotation matrix."""
    m = rotation
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s, (m[1, 0] - m[0, 1]) / s]
    out = np.array(q, dtype=float)
    return out / np.linalg.norm(out)


def multiply(p: np.ndarray, r: np.ndarray) -> np.ndarray:
    """p ⊗ r for quaternions (x, y, z, w); either may be a stack (N, 4)."""
    px, py, pz, pw = np.moveaxis(np.asarray(p), -1, 0)
    rx, ry, rz, rw = np.moveaxis(np.asarray(r), -1, 0)
    return np.stack([pw * rx + px * rw + py * rz - pz * ry,
                     pw * ry - px * rz + py * rw + pz * rx,
                     pw * rz + px * ry - py * rx + pz * rw,
                     pw * rw - px * rx - py * ry - pz * rz], axis=-1)


def rotation_of(q: tuple[float, float, float, float] | np.ndarray) -> np.ndarray:
    x, y, z, w = (float(v) for v in q)
    n = x * x + y * y + z * z + w * w
    if n < 1e-12:
        return np.eye(3)
    s = 2.0 / n
    return np.array([[1 - s * (y * y + z * z), s * (x * y - z * w), s * (x * z + y * w)],
                     [s * (x * y + z * w), 1 - s * (x * x + z * z), s * (y * z - x * w)],
                     [s * (x * z - y * w), s * (y * z + x * w), 1 - s * (x * x + y * y)]])


def yaw_quaternion(yaw: float) -> np.ndarray:
    return np.array([0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)])


def _yaw_of(q: Any) -> float:
    """The yaw of a geometry_msgs Quaternion."""
    x, y, z, w = float(q.x), float(q.y), float(q.z), float(q.w)
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def _skew(a: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


# -- the robot's kinematics ------------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class JointModel:
    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray  # 4x4
    origin_q: np.ndarray  # (x, y, z, w) of the origin's rotation
    axis: np.ndarray  # unit axis in the joint frame
    mimic: tuple[str, float, float] | None  # (joint, multiplier, offset)


@dataclass(slots=True)
class RobotKinematics:
    """The joints of one URDF, in an order where a parent link's joint comes before its children's; the movable
    joints' numbers also as arrays, so all of them move in a few numpy operations."""

    root: str
    movable: list[JointModel]
    fixed: list[JointModel]
    joints: dict[str, JointModel]  # by child link
    soles: list[str]  # the links the robot stands on (named *sole*; else the lowest leaves of the tree)
    urdf_text: str
    _arrays: dict[str, np.ndarray] = field(default_factory=dict)
    _index: dict[str, int] = field(default_factory=dict)  # movable joint name -> its row

    def __post_init__(self) -> None:
        m = self.movable
        self._index = {j.name: i for i, j in enumerate(m)}
        axes = np.array([j.axis for j in m], dtype=float).reshape(-1, 3)
        skew = np.array([_skew(a) for a in axes]).reshape(-1, 3, 3)
        self._arrays = {"axes": axes, "k": skew, "k2": skew @ skew,
                        "origin": np.array([j.origin for j in m], dtype=float).reshape(-1, 4, 4),
                        "origin_q": np.array([j.origin_q for j in m], dtype=float).reshape(-1, 4),
                        "prismatic": np.array([j.type == "prismatic" for j in m], dtype=bool)}

    @property
    def joint_names(self) -> list[str]:
        return [j.name for j in self.movable]

    def values(self, positions: dict[str, float]) -> np.ndarray:
        """Each movable joint's value (mimic joints follow their master; unknown joints stand at 0)."""
        out = np.array([positions.get(j.name, 0.0) for j in self.movable], dtype=float)
        for i, j in enumerate(self.movable):
            if j.mimic is not None:
                master, multiplier, offset = j.mimic
                out[i] = multiplier * positions.get(master, 0.0) + offset
        return out

    def joint_matrices(self, values: np.ndarray) -> np.ndarray:
        """parent -> child (N, 4, 4) of every movable joint at ``values`` (Rodrigues' formula, all at once)."""
        a = self._arrays
        revolute = ~a["prismatic"]
        angle = np.where(revolute, values, 0.0)
        motion = np.tile(np.eye(4), (len(values), 1, 1))
        motion[:, :3, :3] += np.sin(angle)[:, None, None] * a["k"] + (1.0 - np.cos(angle))[:, None, None] * a["k2"]
        motion[:, :3, 3] = a["axes"] * np.where(revolute, 0.0, values)[:, None]
        matrices: np.ndarray = a["origin"] @ motion
        return matrices

    def poses(self, links: list[str], values: np.ndarray) -> dict[str, np.ndarray]:
        """root -> link (4x4) of each of ``links`` at ``values``; each joint on the way is multiplied once."""
        matrices = self.joint_matrices(values) if self.movable else np.zeros((0, 4, 4))
        known: dict[str, np.ndarray] = {self.root: np.eye(4)}

        def pose(link: str) -> np.ndarray:
            found = known.get(link)
            if found is None:
                joint = self.joints.get(link)
                if joint is None:
                    return np.eye(4)  # not a link of this URDF: the root's frame
                i = self._index.get(joint.name)
                found = known[link] = pose(joint.parent) @ (matrices[i] if i is not None else joint.origin)
            return found

        return {link: pose(link) for link in links}

    def moving(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Translations (N, 3) and rotations (N, 4) of the movable joints, parent -> child, in ``movable`` order."""
        a = self._arrays
        prismatic = a["prismatic"]
        half = np.where(prismatic, 0.0, values / 2.0)
        motion = np.concatenate([a["axes"] * np.sin(half)[:, None], np.cos(half)[:, None]], axis=1)
        rotations = multiply(a["origin_q"], motion)
        slide = a["axes"] * np.where(prismatic, values, 0.0)[:, None]
        translations = a["origin"][:, :3, 3] + np.einsum("nij,nj->ni", a["origin"][:, :3, :3], slide)
        return translations, rotations


def _joint_model(joint: Any) -> JointModel:
    origin = np.asarray(joint.origin if joint.origin is not None else np.eye(4), dtype=float)
    axis = np.asarray(joint.axis if joint.axis is not None else (1.0, 0.0, 0.0), dtype=float)
    norm = float(np.linalg.norm(axis))
    axis = axis / norm if norm > 0 else np.array([1.0, 0.0, 0.0])
    mimic = None
    if getattr(joint, "mimic", None) is not None:
        mimic = (joint.mimic.joint, float(joint.mimic.multiplier or 1.0), float(joint.mimic.offset or 0.0))
    kind = joint.type if joint.type in MOVABLE else "fixed"
    return JointModel(joint.name, kind, joint.parent, joint.child, origin, quaternion_of(origin[:3, :3]), axis, mimic)


def load_kinematics(urdf: Path) -> RobotKinematics:
    """The URDF's kinematics (cached while the file is unchanged); DescriptionError if it cannot be read."""
    try:
        return _load_kinematics(str(urdf), urdf.stat().st_mtime)
    except OSError as exc:
        raise DescriptionError(f"URDF {urdf} cannot be read: {exc}") from None


@functools.lru_cache(maxsize=16)
def _load_kinematics(path: str, _mtime: float) -> RobotKinematics:
    import yourdfpy

    text = Path(path).read_text()
    try:
        urdf = yourdfpy.URDF.load(path, load_meshes=False, build_scene_graph=False)
    except Exception as exc:  # yourdfpy and lxml raise several kinds on a broken file
        raise DescriptionError(f"URDF {path} is not a robot description yourdfpy reads: {exc}") from None
    joints = {j.child: _joint_model(j) for j in urdf.robot.joints}
    children = set(joints)
    roots = [link.name for link in urdf.robot.links if link.name not in children]
    if len(roots) != 1:
        raise DescriptionError(f"URDF {path} has {len(roots)} root links ({roots[:3]}), not one")
    order: list[JointModel] = []
    frontier = [roots[0]]
    while frontier:  # breadth first from the root: a parent's joint before its children's
        parent = frontier.pop(0)
        for joint in joints.values():
            if joint.parent == parent:
                order.append(joint)
                frontier.append(joint.child)
    parents = {j.parent for j in order}
    soles = sorted(link for link in children if "sole" in link) or sorted(children - parents)
    return RobotKinematics(root=roots[0], movable=[j for j in order if j.type != "fixed"],
                           fixed=[j for j in order if j.type == "fixed"], joints=joints, soles=soles,
                           urdf_text=text)


def prefixed_description(kinematics: RobotKinematics, robot: str) -> str:
    """The URDF text with every link named as its frame (``robot1/base_link``), so Foxglove's URDF layer fits /tf.
    Joint names stay: joint_states names them."""
    root = ET.fromstring(kinematics.urdf_text)
    for link in root.iter("link"):
        if link.get("name"):
            link.set("name", frame(robot, link.get("name", "")))
    for joint in root.iter("joint"):
        for end in ("parent", "child"):
            element = joint.find(end)
            if element is not None and element.get("link"):
                element.set("link", frame(robot, element.get("link", "")))
    return ET.tostring(root, encoding="unicode")


def frame(robot: str, link: str) -> str:
    return f"{robot}/{link}"


# -- messages -------------------------------------------------------------------------------------------------
def _transform(parent: str, child: str, t: Any, q: Any, when: Any) -> Any:
    return _TransformStamped(
        header=_Header(stamp=when, frame_id=parent), child_frame_id=child,
        transform=_Transform(translation=_Vector3(x=float(t[0]), y=float(t[1]), z=float(t[2])),
                             rotation=_Quaternion(x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3]))))


def _set(transform: Any, t: Any, q: Any, when: Any) -> None:
    """Moves a TransformStamped of a robot's own /tf message (built once, see RobotPose.message)."""
    transform.header.stamp = when
    v, r = transform.transform.translation, transform.transform.rotation
    v.x, v.y, v.z = float(t[0]), float(t[1]), float(t[2])
    r.x, r.y, r.z, r.w = float(q[0]), float(q[1]), float(q[2]), float(q[3])


def tf_message(transforms: list[Any]) -> Any:
    return _TFMessage(transforms=transforms)


def description_message(text: str) -> Any:
    return _String(data=text)


@dataclass(slots=True)
class RobotPose:
    """What one robot said last about where it stands and how it is tilted."""

    positions: dict[str, float] = field(default_factory=dict)
    position: tuple[float, float, float] | None = None  # map -> base_footprint (x, y, yaw)
    odometry: tuple[float, float, float] | None = None  # odom -> base_footprint (x, y, yaw)
    map_to_odom: tuple[float, float, float] = (0.0, 0.0, 0.0)
    imu: tuple[np.ndarray, str] | None = None  # orientation (x, y, z, w) of a frame, and which frame
    next_due: float = 0.0  # monotonic: the next /tf of this robot may go out then
    pending: dict[str, HubMessage] = field(default_factory=dict)  # newest imu, position, odometry: decoded when used
    # the robot's /tf message, built once and moved each time (building 23 transforms cost more than the rest)
    message: Any = None


def _compose(a: tuple[float, float, float], b: tuple[float, float, float]) -> tuple[float, float, float]:
    """Planar poses: a ∘ b."""
    ax, ay, ayaw = a
    bx, by, byaw = b
    c, s = math.cos(ayaw), math.sin(ayaw)
    return ax + c * bx - s * by, ay + s * bx + c * by, ayaw + byaw


def _inverse(a: tuple[float, float, float]) -> tuple[float, float, float]:
    x, y, yaw = a
    c, s = math.cos(yaw), math.sin(yaw)
    return -c * x - s * y, s * x - c * y, -yaw


class RobotStatePublisher:
    """Each robot's tf and tf_static messages, for every robot whose messages it is offered (hub messages, any source).

    ``description_for(robot)`` says where a robot's URDF is (the server's --urdf); a robot whose URDF cannot be read
    gets no frames (said once in the log). ``max_hz`` caps each robot's /tf; ``clock`` is for tests."""

    def __init__(self, description_for: Callable[[str], RobotDescription], max_hz: float = DEFAULT_MAX_HZ,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.description_for = description_for
        self.period = 1.0 / max_hz if max_hz > 0 else 0.0
        self.clock = clock
        self.robots: dict[str, RobotPose] = {}
        self._kinematics: dict[str, RobotKinematics | None] = {}

    def kinematics(self, robot: str) -> RobotKinematics | None:
        """The robot's kinematics (None: its URDF cannot be read); a replayed robot has its logged id's URDF."""
        if robot not in self._kinematics:
            description = self.description_for(keys.robot_in_log(robot))
            try:
                self._kinematics[robot] = load_kinematics(description.urdf)
            except DescriptionError as exc:
                log.warning("no /tf for %s: %s", robot, exc)
                self._kinematics[robot] = None
        return self._kinematics[robot]

    def forget(self, robot: str) -> None:
        self.robots.pop(robot, None)
        self._kinematics.pop(robot, None)

    def note(self, msg: HubMessage) -> None:
        """Keeps the newest imu, position or odometry of a robot, not decoded until its next /tf needs it."""
        if msg.topic in ("imu/data", "position", "walk_odometry"):
            self.robots.setdefault(msg.robot, RobotPose()).pending[msg.topic] = msg

    def offer(self, msg: HubMessage) -> Any | None:
        """A /tf message when this hub message makes one due (joint_states at most ``max_hz``, ground truth), else
        None; encode it before the next offer (see ``dynamic``). schemas.SchemaError if its CDR does not decode."""
        if msg.topic not in TOPICS:
            return None
        if msg.topic == "ground_truth":
            return self.ground_truth(msg)
        if msg.topic != "joint_states":
            self.note(msg)
            return None
        kinematics = self.kinematics(msg.robot)
        if kinematics is None:
            return None
        pose = self.robots.setdefault(msg.robot, RobotPose())
        now = self.clock()
        if now < pose.next_due:
            return None
        pose.next_due = now + self.period
        for name, value in zip(msg.message.name, msg.message.position, strict=False):
            if math.isfinite(value):
                pose.positions[str(name)] = float(value)
        pending, pose.pending = pose.pending, {}
        for newest in pending.values():
            self._apply(pose, newest)
        return self.dynamic(msg.robot, kinematics, pose, stamp(msg.stamp))

    def _apply(self, pose: RobotPose, msg: HubMessage) -> None:
        """An imu, position or odometry message into the robot's pose (SchemaError if it does not decode)."""
        data = msg.message
        if msg.topic == "imu/data":
            q = data.orientation
            orientation = np.array([q.x, q.y, q.z, q.w], dtype=float)
            if np.all(np.isfinite(orientation)) and np.linalg.norm(orientation) > 1e-6:
                pose.imu = (orientation, str(data.header.frame_id))
        elif msg.topic == "walk_odometry":
            p = data.pose.pose
            pose.odometry = (float(p.position.x), float(p.position.y), _yaw_of(p.orientation))
        elif msg.topic == "position":
            p = data.pose
            pose.position = (float(p.x), float(p.y), float(p.theta))
        if pose.position is not None:  # the localisation's correction, as map -> odom
            pose.map_to_odom = _compose(pose.position, _inverse(pose.odometry)) if pose.odometry else pose.position

    def dynamic(self, robot: str, kinematics: RobotKinematics, pose: RobotPose, when: Any) -> Any:
        """The robot's /tf message now. It is the robot's one message object, moved at each call: encode it before
        the next call for the same robot."""
        if pose.message is None:
            zero, level = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)
            ends = [(MAP_FRAME, frame(robot, ODOM)), (frame(robot, ODOM), frame(robot, FOOTPRINT)),
                    (frame(robot, FOOTPRINT), frame(robot, kinematics.root))]
            ends += [(frame(robot, j.parent), frame(robot, j.child)) for j in kinematics.movable]
            pose.message = tf_message([_transform(parent, child, zero, level, when) for parent, child in ends])
        transforms = pose.message.transforms
        mx, my, myaw = pose.map_to_odom
        _set(transforms[0], (mx, my, 0.0), yaw_quaternion(myaw), when)
        ox, oy, oyaw = pose.odometry if pose.odometry and pose.position else (0.0, 0.0, 0.0)
        _set(transforms[1], (ox, oy, 0.0), yaw_quaternion(oyaw), when)
        values = kinematics.values(pose.positions)
        tilt, height = self.stance(kinematics, pose, values)
        _set(transforms[2], (0.0, 0.0, height), tilt, when)
        if kinematics.movable:
            translations, rotations = kinematics.moving(values)
            for transform, t, q in zip(transforms[3:], translations.tolist(), rotations.tolist(), strict=True):
                _set(transform, t, q, when)
        return pose.message

    def stance(self, kinematics: RobotKinematics, pose: RobotPose, values: np.ndarray) -> tuple[np.ndarray, float]:
        """base_footprint -> root: the IMU's roll and pitch (no yaw: that is odometry's), and the height that puts
        the lower sole on the ground."""
        imu_frame = pose.imu[1] if pose.imu is not None and pose.imu[1] in kinematics.joints else None
        poses = kinematics.poses([*kinematics.soles, *([imu_frame] if imu_frame else [])], values)
        level = np.eye(3)
        if pose.imu is not None:
            world_imu = rotation_of(pose.imu[0])
            root_imu = poses[imu_frame][:3, :3] if imu_frame else np.eye(3)
            world_root = world_imu @ root_imu.T
            yaw = math.atan2(world_root[1, 0], world_root[0, 0])
            c, s = math.cos(-yaw), math.sin(-yaw)
            level = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ world_root
        heights = [(level @ poses[sole][:3, 3])[2] for sole in kinematics.soles]
        height = -min(heights) if heights else 0.0
        return quaternion_of(level), float(height)

    def static(self, robot: str, when: Any | None = None) -> Any | None:
        """The robot's fixed joints as one /tf_static message (None: no URDF, or no fixed joint)."""
        kinematics = self.kinematics(robot)
        if kinematics is None or not kinematics.fixed:
            return None
        when = when if when is not None else stamp()
        return tf_message([_transform(frame(robot, j.parent), frame(robot, j.child), j.origin[:3, 3], j.origin_q, when)
                           for j in kinematics.fixed])

    def description(self, robot: str) -> Any | None:
        """``/<robot>/robot_description``: the URDF with the robot's frame names (None: no URDF)."""
        kinematics = self.kinematics(robot)
        return description_message(prefixed_description(kinematics, robot)) if kinematics is not None else None

    def ground_truth(self, msg: HubMessage) -> Any:
        """map -> <robot>/ground_truth/torso for every robot of a simulation's ground truth."""
        data = msg.message
        namespace = keys.REPLAY_NAMESPACE if keys.is_replayed(msg.robot) else ""
        when = stamp(msg.stamp)
        out = []
        for robot, p in zip(data.robot_ids, data.robot_poses, strict=False):
            if not keys.is_valid_name(str(robot)):
                continue  # a name from the network that breaks the rules never becomes a frame
            q = p.orientation
            out.append(_transform(MAP_FRAME, frame(namespace + str(robot), GROUND_TRUTH),
                                  (p.position.x, p.position.y, p.position.z), (q.x, q.y, q.z, q.w), when))
        return tf_message(out)
