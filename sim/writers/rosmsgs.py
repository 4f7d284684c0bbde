"""ROS message objects for the bag exporter, built with ``rosbags.typesys`` (no ROS install needed).

One :class:`RosMessages` per bag: ROS 1 (Noetic type store, ``serialize_ros1``) or ROS 2 (Humble
type store, CDR). Field names differ between the two (``CameraInfo.D/K/R/P`` vs ``d/k/r/p``,
``Header.seq`` only in ROS 1); this module is the one place that knows it.

Conventions of the messages (as EuRoC's own bags and the ROS REPs):

- ``header.stamp`` = the sample's int64 ns time split into ``sec``/``nanosec`` (exact);
- images: ``mono8`` (grey PNG), ``rgb8`` (colour PNG, converted from OpenCV's BGR), ``mono16``;
- ``CameraInfo``: ``plumb_bob`` with OpenCV's ``(k1, k2, p1, p2, k3)``, ``R = I``, ``P = K [R_c_c0 | t_c_c0]``
  for rectified pairs (``P[0,3] = -fx * baseline`` for the right camera, as KITTI) and ``K [I | 0]`` otherwise;
- ``Imu``: orientation unknown (``orientation_covariance[0] = -1``, REP 145); angular velocity and linear
  acceleration covariances are the discrete white-noise variances ``density^2 * rate`` on the diagonal;
- poses: ``geometry_msgs/PoseStamped`` (position + Hamilton quaternion ``x, y, z, w``);
- wheels: ``sensor_msgs/JointState`` with the wheel angles in radians (``ticks * 2 pi / ticks_per_rev``).
"""
from __future__ import annotations

import numpy as np

from rigs.geometry import quat_wxyz_from_R

TF_MESSAGE_ROS1 = "geometry_msgs/TransformStamped[] transforms\n"


class RosMessages:
    """Message constructors and the serializer of one ROS version (``ros1=True``: ROS 1)."""

    def __init__(self, ros1: bool):
        from rosbags.typesys import Stores, get_typestore, get_types_from_msg
        self.ros1 = bool(ros1)
        self.store = get_typestore(Stores.ROS1_NOETIC if self.ros1 else Stores.ROS2_HUMBLE)
        if "tf2_msgs/msg/TFMessage" not in self.store.types:      # Noetic's store lacks it
            self.store.register(get_types_from_msg(TF_MESSAGE_ROS1, "tf2_msgs/msg/TFMessage"))
        self.types = self.store.types
        self._seq: dict = {}

    def serialize(self, msg) -> memoryview:
        if self.ros1:
            return self.store.serialize_ros1(msg, msg.__msgtype__)
        return self.store.serialize_cdr(msg, msg.__msgtype__)

    # ------------------------------------------------------------------ building blocks
    def stamp(self, t_ns: int):
        sec, nsec = divmod(int(t_ns), 1_000_000_000)
        return self.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec)

    def header(self, t_ns: int, frame_id: str, stream: str = ""):
        """ROS 1 headers count ``seq`` per (frame_id, stream) from 0."""
        Header = self.types["std_msgs/msg/Header"]
        if not self.ros1:
            return Header(stamp=self.stamp(t_ns), frame_id=frame_id)
        seq = self._seq.get((frame_id, stream), 0)
        self._seq[(frame_id, stream)] = seq + 1
        return Header(seq=seq, stamp=self.stamp(t_ns), frame_id=frame_id)

    def pose(self, T: np.ndarray):
        """(4,4) ``T_a_b`` -> geometry_msgs/Pose of b in a."""
        t = self.types
        w, x, y, z = (float(v) for v in quat_wxyz_from_R(np.asarray(T)[:3, :3]))
        p = np.asarray(T, dtype=float)[:3, 3]
        return t["geometry_msgs/msg/Pose"](position=t["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=p[2]),
                                           orientation=t["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w))

    def transform(self, t_ns: int, parent: str, child: str, T_parent_child: np.ndarray):
        t = self.types
        pose = self.pose(T_parent_child)
        tr = t["geometry_msgs/msg/Transform"](
            translation=t["geometry_msgs/msg/Vector3"](x=pose.position.x, y=pose.position.y, z=pose.position.z),
            rotation=pose.orientation)
        return t["geometry_msgs/msg/TransformStamped"](header=self.header(t_ns, parent), child_frame_id=child,
                                                       transform=tr)

    def vector3(self, v):
        return self.types["geometry_msgs/msg/Vector3"](x=float(v[0]), y=float(v[1]), z=float(v[2]))

    # ------------------------------------------------------------------ messages
    def tf_static(self, t_ns: int, parent: str, children: dict):
        """``children``: {child frame id: (4,4) T_parent_child} -> tf2_msgs/TFMessage."""
        items = [self.transform(t_ns, parent, name, T) for name, T in children.items()]
        return self.types["tf2_msgs/msg/TFMessage"](transforms=items)

    def image(self, t_ns: int, frame_id: str, img: np.ndarray):
        """(H,W) uint8 -> mono8, (H,W) uint16 -> mono16, (H,W,3) uint8 RGB -> rgb8 (row-major, no padding)."""
        img = np.ascontiguousarray(img)
        if img.ndim == 3:
            encoding = "rgb8"
        else:
            encoding = "mono16" if img.dtype == np.uint16 else "mono8"
        data = img.view(np.uint8).reshape(-1)
        return self.types["sensor_msgs/msg/Image"](
            header=self.header(t_ns, frame_id), height=img.shape[0], width=img.shape[1], encoding=encoding,
            is_bigendian=0, step=int(img.strides[0]), data=data)

    def camera_info(self, t_ns: int, frame_id: str, cam, P: np.ndarray):
        """``cam``: rigs.Camera; ``P`` (3,4). ``distortion_model`` as ROS names them (sensor_msgs'
        distortion_models.h): ``plumb_bob`` with OpenCV's 5 radtan coefficients, or ``equidistant`` with the
        4 ``cv2.fisheye`` coefficients ``k1..k4`` of an equidistant camera."""
        K = np.array([[cam.fx, 0.0, cam.cx], [0.0, cam.fy, cam.cy], [0.0, 0.0, 1.0]])
        arrays = {"D": np.asarray(cam.dist, dtype=np.float64), "K": K.reshape(-1), "R": np.eye(3).reshape(-1),
                  "P": np.asarray(P, dtype=np.float64).reshape(-1)}
        if not self.ros1:
            arrays = {k.lower(): v for k, v in arrays.items()}
        roi = self.types["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0,
                                                             do_rectify=False)
        return self.types["sensor_msgs/msg/CameraInfo"](
            header=self.header(t_ns, frame_id, "info"), height=cam.height, width=cam.width,
            distortion_model="equidistant" if cam.is_fisheye else "plumb_bob", binning_x=0, binning_y=0, roi=roi, **arrays)

    def imu(self, t_ns: int, frame_id: str, gyro, accel, var_gyro: float, var_accel: float):
        q = self.types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
        cov_q = np.zeros(9)
        cov_q[0] = -1.0                                   # REP 145: orientation not provided
        return self.types["sensor_msgs/msg/Imu"](
            header=self.header(t_ns, frame_id), orientation=q, orientation_covariance=cov_q,
            angular_velocity=self.vector3(gyro), angular_velocity_covariance=np.diag([var_gyro] * 3).reshape(-1),
            linear_acceleration=self.vector3(accel),
            linear_acceleration_covariance=np.diag([var_accel] * 3).reshape(-1))

    def pose_stamped(self, t_ns: int, frame_id: str, T: np.ndarray):
        return self.types["geometry_msgs/msg/PoseStamped"](header=self.header(t_ns, frame_id), pose=self.pose(T))

    def joint_state(self, t_ns: int, frame_id: str, names: list, positions):
        return self.types["sensor_msgs/msg/JointState"](
            header=self.header(t_ns, frame_id), name=list(names), position=np.asarray(positions, dtype=np.float64),
            velocity=np.zeros(0), effort=np.zeros(0))
