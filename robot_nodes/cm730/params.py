"""The cm730 node's parameters: the servo bus's, and (prefixed ``mujoco:`` in their docs) those the simulation's
extras read (robot_nodes/sim/extras.py), declared here so one params.yaml section sets both."""

from __future__ import annotations

from dataclasses import dataclass

from robot_nodes.runtime import param


@dataclass
class Cm730Params:
    backend: str = param("mujoco", choices=["mujoco", "dynamixel"], doc="servo bus: simulated or real Dynamixel")
    publish_rate: float = param(100.0, range=(1.0, 1000.0),
                                doc="Hz of joint_states and imu/data (the motion chain runs at 100 Hz)")
    servo_data_rate: float = param(5.0, range=(0.1, 50.0), doc="Hz of servo_data (temperatures, voltage)")
    device: str = param("/dev/ttyUSB0", doc="dynamixel: serial port of the servo bus")
    baudrate: int = param(1000000, range=(9600, 4500000), doc="dynamixel: bus baud rate")
    model: str = param("minibot", startup=True, doc="robot model; its URDF is robots/<model>/urdf/<model>.urdf")
    urdf: str = param("", startup=True, doc="URDF whose joint limits every goal is clamped to; empty = the model's")
    limit_margin_deg: float = param(
        1.0, range=(0.0, 10.0), startup=True,
        doc="goals stay this far inside each URDF joint limit: a servo overshoots its goal by a few ticks and the "
            "URDF limit is where parts touch")
    real_time_factor: float = param(1.0, range=(0.0, 100.0), doc="mujoco: sim speed, 0 = as fast as possible")
    imu_gyro_noise: float = param(0.005, range=(0.0, 1.0), doc="mujoco: gyro noise std dev, rad/s")
    imu_accel_noise: float = param(0.05, range=(0.0, 5.0), doc="mujoco: accelerometer noise std dev, m/s^2")
    imu_orientation_noise: float = param(0.002, range=(0.0, 0.5), doc="mujoco: orientation noise std dev, rad")
    camera_rate: float = param(10.0, range=(0.1, 60.0), doc="mujoco: Hz of detections (images: image_rate)")
    image_rate: float = param(10.0, range=(0.1, 60.0),
                              doc="mujoco: Hz of rendered camera images (at most camera_rate; detections keep it)")
    camera_width: int = param(320, range=(16, 640), doc="mujoco: image width, px")
    camera_height: int = param(240, range=(16, 480), doc="mujoco: image height, px")
    jpeg_quality: int = param(80, range=(10, 100), doc="mujoco: JPEG quality of camera/image/compressed")
    render_camera: bool = param(True, doc="mujoco: render images (only while someone subscribes)")
    # the perception stand-ins (robot_nodes/sim/perception.py): defaults are what a decent robot's vision and
    # localization give; all 0 (and max distance 100 m) is the exact ground truth of what is in view
    detection_pixel_noise: float = param(0.0, range=(0.0, 50.0), doc="mujoco: std dev of image detections, px")
    detection_relative_noise: float = param(0.02, range=(0.0, 2.0),
                                            doc="mujoco: std dev of relative positions right at the lens, m")
    detection_noise_per_m: float = param(0.05, range=(0.0, 1.0),
                                         doc="mujoco: std dev added per metre of distance (a far ball is noisier)")
    detection_max_distance: float = param(6.0, range=(0.5, 100.0),
                                          doc="mujoco: ball and robots farther from the camera are not seen, m")
    detection_dropout: float = param(0.1, range=(0.0, 1.0),
                                     doc="mujoco: probability a detection in view is missed (false negative)")
    position_noise: float = param(0.08, range=(0.0, 2.0), doc="mujoco: std dev of the own position (x, y), m")
    yaw_noise: float = param(0.05, range=(0.0, 1.0), doc="mujoco: std dev of the own heading, rad")
    position_losses_per_min: float = param(1.0, range=(0.0, 60.0),
                                           doc="mujoco: how often the localization is lost (no position)")
    position_loss_s: float = param(2.0, range=(0.0, 60.0), doc="mujoco: how long each loss lasts, s")
    own_half: str = param("-x", choices=["-x", "+x"],
                          doc="mujoco: the half of the simulated field this robot's team defends; position is "
                              "published in the team's frame (own goal at -x), as a localization gives it")
    ground_truth_rate: float = param(20.0, range=(0.0, 200.0),
                                     doc="mujoco: Hz of ground_truth (every robot's pose: one node of a world sends "
                                         "it, the others have 0)")

