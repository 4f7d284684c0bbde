"""Export a dataset folder (EuRoC or KITTI layout, ours or real) to a ROS 1 bag or a ROS 2 bag.

Written with the ``rosbags`` library: ROS 1 bag format 2.0, or a ROS 2 bag folder with the
``sqlite3`` or ``mcap`` storage plugin. No ROS installation is needed. The dataset is read through
the reader API (:func:`vo.dataset.open_dataset`); image bytes come from the PNG files themselves.

Topics (``/cam0/image_raw``, ``/cam1/image_raw`` and ``/imu0`` as in EuRoC's own bags)::

    /cam0/image_raw, /cam1/image_raw        sensor_msgs/Image (mono8 | rgb8 | mono16), frame cam0 / cam1
    /cam0/camera_info, /cam1/camera_info    sensor_msgs/CameraInfo (plumb_bob), one per image
    /imu0                                   sensor_msgs/Imu, frame imu0 (datasets with an IMU)
    /tf_static                              tf2_msgs/TFMessage at the first time: body -> imu0, cam0, cam1
    /groundtruth/pose                       geometry_msgs/PoseStamped, the dataset's ground truth
                                            (EuRoC: T_w_i at the ground-truth rate, frame "world")
    /groundtruth/cam0                       geometry_msgs/PoseStamped T_w_c0 at the frame times
    /wheels                                 sensor_msgs/JointState (left_wheel, right_wheel angles, rad)
                                            when the dataset root holds wheels.csv

``truth=False`` (``export --no-truth``) leaves out ``/groundtruth/*``: a sensor-only bag for handing data
to a program under test.

Every message's log time and ``header.stamp`` equal the dataset's int64 ns time of that sample.
Messages are written in time order (ties: tf, camera_info, image, imu, ground truth, wheels).
"""
from __future__ import annotations

import heapq
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rigs.geometry import inv_T
from sim.errors import SimError
from vo.dataset import open_dataset

KINDS = ("rosbag1", "rosbag2")
STORAGES = ("sqlite3", "mcap")
FRAME_IDS = {"w": "world", "c0_0": "cam0_first"}


@dataclass(frozen=True)
class ExportResult:
    path: str
    kind: str
    storage: str
    counts: dict = field(default_factory=dict)      # topic -> number of messages

    def to_dict(self) -> dict:
        return {"path": self.path, "kind": self.kind, "storage": self.storage, "counts": dict(self.counts)}


def check_kind(kind: str, storage: str) -> None:
    if kind not in KINDS:
        raise SimError(f"--to: unknown bag kind {kind!r}; valid: {', '.join(KINDS)}")
    if storage not in STORAGES:
        raise SimError(f"--storage: unknown ROS 2 storage {storage!r}; valid: {', '.join(STORAGES)}")


def export_rosbag(dataset_dir, out_path, kind: str = "rosbag1", storage: str = "mcap",
                  allow_incomplete: bool = False, truth: bool = True) -> ExportResult:
    """Write the dataset in ``dataset_dir`` as a bag at ``out_path`` (a ``.bag`` file for rosbag1,
    a new folder for rosbag2; ``storage`` applies to rosbag2 only). ``out_path`` must not exist.
    A failed export removes what it wrote. ``allow_incomplete``: the generator's own bag step, which
    converts its folder before marking it complete."""
    check_kind(kind, storage)
    out_path = Path(out_path)
    if out_path.exists():
        raise SimError(f"--out: {out_path} already exists; remove it or choose another path")
    if not out_path.parent.is_dir():
        raise SimError(f"--out: folder {out_path.parent} does not exist")
    if (out_path.suffix == ".bag") != (kind == "rosbag1"):     # readers (rosbags' AnyReader) go by the suffix
        raise SimError(f"--out: {out_path}: a rosbag1 bag is a file named *.bag, a rosbag2 bag a folder not "
                       f"named *.bag")
    ds = open_dataset(dataset_dir, allow_incomplete=allow_incomplete)
    try:
        counts = _write(ds, out_path, kind, storage, truth)
    except BaseException:
        if out_path.is_dir():
            shutil.rmtree(out_path, ignore_errors=True)
        elif out_path.exists():
            out_path.unlink()
        raise
    return ExportResult(str(out_path), kind, storage if kind == "rosbag2" else "bag format 2.0", counts)


def _open_writer(out_path: Path, kind: str, storage: str):
    if kind == "rosbag1":
        from rosbags.rosbag1 import Writer
        return Writer(out_path)
    from rosbags.rosbag2 import StoragePlugin, Writer
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    return Writer(out_path, version=Writer.VERSION_LATEST, storage_plugin=plugin)


def _latched_qos():
    """ROS 2 QoS of /tf_static: keep last 1, reliable, transient local (late joiners get it)."""
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
    zero = QosTime(0, 0)
    return Qos(QosHistory.KEEP_LAST, 1, QosReliability.RELIABLE, QosDurability.TRANSIENT_LOCAL, zero, zero,
               QosLiveliness.AUTOMATIC, zero, False)


def _write(ds, out_path: Path, kind: str, storage: str, truth: bool = True) -> dict:
    from sim.writers.rosmsgs import RosMessages
    msgs = RosMessages(ros1=(kind == "rosbag1"))
    streams = dataset_streams(ds, msgs, truth)
    counts = {topic: 0 for topic in streams}
    with _open_writer(out_path, kind, storage) as writer:
        conns = {}
        for topic, (msgtype, _) in streams.items():
            if topic == "/tf_static":
                extra = {"latching": 1} if msgs.ros1 else {"offered_qos_profiles": [_latched_qos()]}
            else:
                extra = {}
            conns[topic] = writer.add_connection(topic, msgtype, typestore=msgs.store, **extra)
        merged = heapq.merge(*(_tagged(topic, prio, it) for prio, (topic, (_, it)) in enumerate(streams.items())),
                             key=lambda item: item[:2])
        for t_ns, _, topic, build in merged:
            writer.write(conns[topic], int(t_ns), msgs.serialize(build()))
            counts[topic] += 1
    return counts


def _tagged(topic: str, prio: int, items):
    for t_ns, build in items:
        yield int(t_ns), prio, topic, build


def dataset_streams(ds, msgs, truth: bool = True) -> dict:
    """{topic: (msgtype, iterator of (t_ns, () -> message))} in tie-break order; no ``/groundtruth/*``
    unless ``truth``."""
    rig, t_frames = ds.rig, ds.frame_times_ns
    out = {}
    t_first = _first_time(ds)
    body = {"imu0": rig.imu.T_b_i_array, "cam0": rig.cameras[0].T_b_c_array, "cam1": rig.cameras[1].T_b_c_array}
    out["/tf_static"] = ("tf2_msgs/msg/TFMessage", iter([(t_first, lambda: msgs.tf_static(t_first, "body", body))]))
    for k in (0, 1):
        out[f"/cam{k}/camera_info"] = ("sensor_msgs/msg/CameraInfo", _info_items(t_frames, k, rig, msgs,
                                                                               ds.images_are_rectified))
    for k in (0, 1):
        out[f"/cam{k}/image_raw"] = ("sensor_msgs/msg/Image", _image_items(ds, k, msgs))
    if ds.imu is not None and len(ds.imu.t_ns):
        out["/imu0"] = ("sensor_msgs/msg/Imu", _imu_items(ds.imu, rig.imu, msgs))
    gt = ds.groundtruth if truth else None
    if gt is not None and len(gt.t_ns):
        frame_id = FRAME_IDS.get(gt.ref, gt.ref)
        out["/groundtruth/pose"] = ("geometry_msgs/msg/PoseStamped",
                                    ((t, _bind(msgs.pose_stamped, t, frame_id, T)) for t, T in zip(gt.t_ns, gt.T)))
        c0 = ds.groundtruth_cam0()
        frame_c0 = FRAME_IDS.get(c0.ref, c0.ref)
        out["/groundtruth/cam0"] = ("geometry_msgs/msg/PoseStamped",
                                    ((t, _bind(msgs.pose_stamped, t, frame_c0, T)) for t, T in zip(c0.t_ns, c0.T)))
    wheels = ds.wheels
    if wheels is not None and len(wheels.t_ns):
        if rig.wheels is None:
            raise SimError(f"{ds.path}: wheel ticks (wheels.csv) but the rig has no wheels section (ticks_per_rev)")
        rad_per_tick = 2 * np.pi / int(rig.wheels.ticks_per_rev)
        ticks = np.column_stack([wheels.left_ticks, wheels.right_ticks])
        out["/wheels"] = ("sensor_msgs/msg/JointState",
                          ((t, _bind(msgs.joint_state, t, "body", ["left_wheel", "right_wheel"], row * rad_per_tick))
                           for t, row in zip(wheels.t_ns, ticks)))
    return out


def _info_items(t_frames, k: int, rig, msgs, rectified: bool):
    """Camera ``k``'s CameraInfo at every frame time (its own function: a generator expression in the
    loop over cameras would see the last camera's ``k`` when it is consumed)."""
    P = projection(rig, k, rectified)
    return ((t, _bind(msgs.camera_info, t, f"cam{k}", rig.cameras[k], P)) for t in t_frames)


def _bind(fn, *args):
    return lambda: fn(*args)


def _first_time(ds) -> int:
    starts = [int(ds.frame_times_ns[0])] if len(ds) else []
    if ds.imu is not None and len(ds.imu.t_ns):
        starts.append(int(ds.imu.t_ns[0]))
    if not starts:
        raise SimError(f"{ds.path}: no frames and no IMU samples; nothing to export")
    return min(starts)


def projection(rig, k: int, rectified: bool) -> np.ndarray:
    """(3,4) ``P`` of camera ``k``: ``K [R_c_c0 | t_c_c0]`` for a rectified pair, else ``K [I | 0]``."""
    cam = rig.cameras[k]
    K = np.array([[cam.fx, 0.0, cam.cx], [0.0, cam.fy, cam.cy], [0.0, 0.0, 1.0]])
    T = inv_T(cam.T_b_c_array) @ rig.cameras[0].T_b_c_array if rectified else np.eye(4)
    return K @ T[:3, :4]


def _image_items(ds, k: int, msgs):
    for j, t in enumerate(ds.frame_times_ns):
        path = ds.image_files(j)[k]
        yield int(t), _bind(_image_message, msgs, int(t), f"cam{k}", path)


def _image_message(msgs, t_ns: int, frame_id: str, path: Path):
    return msgs.image(t_ns, frame_id, load_image(path))


def load_image(path: Path) -> np.ndarray:
    """Image file -> (H,W) grey or (H,W,3) RGB array as stored (no conversion of grey levels)."""
    import cv2
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise SimError(f"{path}: cannot read image")
    if img.ndim == 3 and img.shape[2] == 4:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2RGB)
    elif img.ndim == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2RGB)
    return img


def _imu_items(imu, imu_model, msgs):
    var_g = imu_model.gyro_noise_density ** 2 * imu_model.rate_hz
    var_a = imu_model.accel_noise_density ** 2 * imu_model.rate_hz
    for t, g, a in zip(imu.t_ns, imu.gyro, imu.accel):
        yield int(t), _bind(msgs.imu, int(t), "imu0", g, a, var_g, var_a)
