"""Short names of the standard ROS 2 Jazzy message classes pitchside uses; rosbags' typestore decodes into them."""

from __future__ import annotations

from rosbags.typesys.stores import ros2_jazzy as _jazzy

Duration = _jazzy.builtin_interfaces__msg__Duration
Time = _jazzy.builtin_interfaces__msg__Time
DiagnosticArray = _jazzy.diagnostic_msgs__msg__DiagnosticArray
DiagnosticStatus = _jazzy.diagnostic_msgs__msg__DiagnosticStatus
KeyValue = _jazzy.diagnostic_msgs__msg__KeyValue
Point = _jazzy.geometry_msgs__msg__Point
Pose = _jazzy.geometry_msgs__msg__Pose
Pose2D = _jazzy.geometry_msgs__msg__Pose2D
PoseWithCovariance = _jazzy.geometry_msgs__msg__PoseWithCovariance
Quaternion = _jazzy.geometry_msgs__msg__Quaternion
Twist = _jazzy.geometry_msgs__msg__Twist
TwistWithCovariance = _jazzy.geometry_msgs__msg__TwistWithCovariance
Vector3 = _jazzy.geometry_msgs__msg__Vector3
Odometry = _jazzy.nav_msgs__msg__Odometry
CameraInfo = _jazzy.sensor_msgs__msg__CameraInfo
CompressedImage = _jazzy.sensor_msgs__msg__CompressedImage
Image = _jazzy.sensor_msgs__msg__Image
Imu = _jazzy.sensor_msgs__msg__Imu
JointState = _jazzy.sensor_msgs__msg__JointState
Log = _jazzy.rcl_interfaces__msg__Log
Temperature = _jazzy.sensor_msgs__msg__Temperature
Bool = _jazzy.std_msgs__msg__Bool
Header = _jazzy.std_msgs__msg__Header
String = _jazzy.std_msgs__msg__String
JointTrajectory = _jazzy.trajectory_msgs__msg__JointTrajectory
JointTrajectoryPoint = _jazzy.trajectory_msgs__msg__JointTrajectoryPoint
