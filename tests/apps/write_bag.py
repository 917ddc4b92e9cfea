# Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
"""Writes a ROS bag from a simulated sequence dumped by bag_test (with the rosbags writer).

  write_bag.py SRC BAG --storage ros1|sqlite3|mcap --odometry odometry|joints|speeds|twist [--wheels R,B]
               [--drop TOPIC] [--encoding ENC] [--swap N]

The last three spoil the bag for the bad-input tests: a topic left out, the camera's images
labelled with another encoding, the header stamps of frames N and N + 1 swapped.

--layout tum writes an RGB-D sequence as TUM RGB-D's bags have it (Sturm et al., IROS 2012, "File
Formats"; fr2's Pioneer sequences): rgb8 colour on /camera/rgb/image_color and 32FC1 depth in
metres on /camera/depth/image, their camera_info with the ROS driver's default intrinsics (525,
319.5, 239.5), the robot's odometry as nav_msgs/Odometry on /pose, and ROS 1's tf/tfMessage on /tf:
the motion capture's /world -> /kinect and the driver's /odom -> /base_link, both moving, and the
Kinect's fixed frames down to /openni_rgb_optical_frame. No transform joins the robot to the camera.

SRC holds frames.csv (t_ns, left.npy[, right.npy or depth.npy]), odometry.csv (t_ns, x, y, theta,
ticks_left, ticks_right, ticks_per_revolution, v, omega), camera.txt (fx fy cx cy width height
baseline) and T_b_c.txt (16 numbers, row by row). Topics as a robot's driver publishes them.
"""
import argparse
import math
import sys
import tempfile
from pathlib import Path

import numpy as np
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin, Writer as Writer2
from rosbags.typesys import Stores, get_types_from_msg, get_typestore


def main():
    p = argparse.ArgumentParser()
    p.add_argument("src")
    p.add_argument("bag")
    p.add_argument("--storage", choices=["ros1", "sqlite3", "mcap"], required=True)
    p.add_argument("--odometry", choices=["odometry", "joints", "speeds", "twist"], required=True)
    p.add_argument("--wheels", default="0.08,0.4", help="speeds: the wheels' radius and track, m")
    p.add_argument("--compressed", action="store_true", help="the camera as CompressedImage (png)")
    p.add_argument("--drop", default="")
    p.add_argument("--encoding", default="")
    p.add_argument("--swap", type=int, default=-1)
    p.add_argument("--layout", choices=["driver", "tum"], default="driver")
    a = p.parse_args()
    src = Path(a.src)
    ros1 = a.storage == "ros1"
    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if ros1:  # ROS 1's tf2_msgs and tf are not in rosbags' noetic store: their definitions, as ROS 1 has them
        for name in ("tf2_msgs/msg/TFMessage", "tf/msg/tfMessage"):
            ts.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", name))
    if a.layout == "tum":
        tum(a, src, ts)
        return
    T = ts.types
    fx, fy, cx, cy, width, height, baseline = (float(v) for v in (src / "camera.txt").read_text().split())
    tbc = np.array([float(v) for v in (src / "T_b_c.txt").read_text().split()]).reshape(4, 4)

    def stamp(ns):
        return T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)

    def header(ns, frame):
        kw = {"seq": 0} if ros1 else {}
        return T["std_msgs/msg/Header"](stamp=stamp(ns), frame_id=frame, **kw)

    def image(ns, array, frame):
        enc = "16UC1" if array.dtype == np.uint16 else "mono8" if array.ndim == 2 else "bgr8"
        enc = a.encoding if a.encoding and frame == "camera_left" and array.dtype != np.uint16 else enc
        data = np.ascontiguousarray(array).view(np.uint8).reshape(-1)
        return T["sensor_msgs/msg/Image"](header=header(ns, frame), height=array.shape[0], width=array.shape[1],
                                          encoding=enc, is_bigendian=0, step=data.size // array.shape[0], data=data)

    def compressed(ns, array, frame):
        sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "apps"))
        import rvwo_bag  # its PNG writer: lossless, so the pixels come back as they were
        with tempfile.TemporaryDirectory() as d:
            rvwo_bag.png(Path(d) / "f.png", array if array.ndim == 2 else array[:, :, ::-1])
            data = np.frombuffer((Path(d) / "f.png").read_bytes(), np.uint8)
        return T["sensor_msgs/msg/CompressedImage"](header=header(ns, frame), format="png", data=data)

    def info(ns, frame, tx):
        roi = T["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
        k = np.array([fx, 0, cx, 0, fy, cy, 0, 0, 1], float)
        pm = np.array([fx, 0, cx, tx, 0, fy, cy, 0, 0, 0, 1, 0], float)
        names = ("D", "K", "R", "P") if ros1 else ("d", "k", "r", "p")
        kw = dict(zip(names, (np.zeros(5), k, np.eye(3).reshape(-1), pm)))
        return T["sensor_msgs/msg/CameraInfo"](header=header(ns, frame), height=int(height), width=int(width),
                                               distortion_model="plumb_bob", binning_x=0, binning_y=0, roi=roi, **kw)

    def quaternion(R):
        w = math.sqrt(max(0.0, 1 + R[0, 0] + R[1, 1] + R[2, 2])) / 2
        x = math.copysign(math.sqrt(max(0.0, 1 + R[0, 0] - R[1, 1] - R[2, 2])) / 2, R[2, 1] - R[1, 2])
        y = math.copysign(math.sqrt(max(0.0, 1 - R[0, 0] + R[1, 1] - R[2, 2])) / 2, R[0, 2] - R[2, 0])
        z = math.copysign(math.sqrt(max(0.0, 1 - R[0, 0] - R[1, 1] + R[2, 2])) / 2, R[1, 0] - R[0, 1])
        return T["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)

    def vec(x, y, z, kind="geometry_msgs/msg/Vector3"):
        return T[kind](x=x, y=y, z=z)

    frames = [line.split(",") for line in (src / "frames.csv").read_text().split("\n") if line]
    odo = [line.split(",") for line in (src / "odometry.csv").read_text().split("\n") if line]
    messages = []  # (ns, topic, type, message)
    for i, f in enumerate(frames):
        ns = int(f[0])
        left = np.load(src / f[1])
        swapped = ns
        if a.swap >= 0 and i in (a.swap, a.swap + 1):  # the two header stamps exchanged
            swapped = int(frames[2 * a.swap + 1 - i][0])
        if a.compressed:
            messages.append((ns, "/camera/left/image_raw/compressed", "sensor_msgs/msg/CompressedImage",
                             compressed(swapped, left, "camera_left")))
        else:
            messages.append((ns, "/camera/left/image_raw", "sensor_msgs/msg/Image", image(swapped, left, "camera_left")))
        messages.append((ns, "/camera/left/camera_info", "sensor_msgs/msg/CameraInfo", info(ns, "camera_left", 0.0)))
        if len(f) > 2:
            other = np.load(src / f[2])
            if other.dtype == np.uint16:
                messages.append((ns, "/camera/depth/image_raw", "sensor_msgs/msg/Image",
                                 image(ns, other, "camera_left")))
            else:
                messages.append((ns, "/camera/right/image_raw", "sensor_msgs/msg/Image",
                                 image(ns, other, "camera_right")))
                messages.append((ns, "/camera/right/camera_info", "sensor_msgs/msg/CameraInfo",
                                 info(ns, "camera_right", -fx * baseline)))
    for o in odo:
        ns = int(o[0])
        x, y, theta, tl, tr, tpr, v, omega = (float(s) for s in o[1:])
        if a.odometry == "odometry":
            pose = T["geometry_msgs/msg/Pose"](position=vec(x, y, 0.0, "geometry_msgs/msg/Point"),
                                               orientation=T["geometry_msgs/msg/Quaternion"](
                                                   x=0.0, y=0.0, z=math.sin(theta / 2), w=math.cos(theta / 2)))
            twist = T["geometry_msgs/msg/Twist"](linear=vec(v, 0.0, 0.0), angular=vec(0.0, 0.0, omega))
            msg = T["nav_msgs/msg/Odometry"](
                header=header(ns, "odom"), child_frame_id="base_link",
                pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
                twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=np.zeros(36)))
            messages.append((ns, "/odom", "nav_msgs/msg/Odometry", msg))
        elif a.odometry == "joints":
            k = 2 * math.pi / tpr
            msg = T["sensor_msgs/msg/JointState"](header=header(ns, ""), name=["left_wheel_joint", "right_wheel_joint"],
                                                  position=np.array([tl * k, tr * k]), velocity=np.zeros(0),
                                                  effort=np.zeros(0))
            messages.append((ns, "/joint_states", "sensor_msgs/msg/JointState", msg))
        elif a.odometry == "speeds":
            r, b = (float(s) for s in a.wheels.split(","))
            msg = T["sensor_msgs/msg/JointState"](header=header(ns, ""), name=["left_wheel_joint", "right_wheel_joint"],
                                                  position=np.zeros(0), effort=np.zeros(0),
                                                  velocity=np.array([(v - omega * b / 2) / r, (v + omega * b / 2) / r]))
            messages.append((ns, "/joint_states", "sensor_msgs/msg/JointState", msg))
        else:
            twist = T["geometry_msgs/msg/Twist"](linear=vec(v, 0.0, 0.0), angular=vec(0.0, 0.0, omega))
            msg = T["geometry_msgs/msg/TwistStamped"](header=header(ns, "base_link"), twist=twist)
            messages.append((ns, "/wheel_twist", "geometry_msgs/msg/TwistStamped", msg))
    tf = T["geometry_msgs/msg/TransformStamped"](
        header=header(int(frames[0][0]), "base_link"), child_frame_id="camera_left",
        transform=T["geometry_msgs/msg/Transform"](translation=vec(*tbc[:3, 3]), rotation=quaternion(tbc[:3, :3])))
    messages.insert(0, (int(frames[0][0]), "/tf_static", "tf2_msgs/msg/TFMessage", T["tf2_msgs/msg/TFMessage"](
        transforms=[tf])))
    write(a, ts, messages)


def write(a, ts, messages):
    """The messages (ns, topic, type, message), in time order, into the bag; --drop's topic left out."""
    messages.sort(key=lambda m: m[0])
    ros1 = a.storage == "ros1"
    if ros1:
        writer = Writer1(a.bag)
    else:
        plugin = StoragePlugin.MCAP if a.storage == "mcap" else StoragePlugin.SQLITE3
        writer = Writer2(a.bag, version=9, storage_plugin=plugin)
    with writer:
        conns = {}
        for ns, topic, typ, msg in messages:
            if topic == a.drop:
                continue
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, typ, typestore=ts)
            data = ts.serialize_ros1(msg, typ) if ros1 else ts.serialize_cdr(msg, typ)
            writer.write(conns[topic], ns, data)


def tum(a, src, ts):
    """The RGB-D sequence in SRC as a TUM RGB-D bag (ROS 1; see --layout above)."""
    T = ts.types

    def header(ns, frame):
        return T["std_msgs/msg/Header"](seq=0, stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9,
                                                                                     nanosec=ns % 10**9),
                                        frame_id=frame)

    def image(ns, array, encoding, frame):
        data = np.ascontiguousarray(array).view(np.uint8).reshape(-1)
        return T["sensor_msgs/msg/Image"](header=header(ns, frame), height=array.shape[0], width=array.shape[1],
                                          encoding=encoding, is_bigendian=0, step=data.size // array.shape[0],
                                          data=data)

    def info(ns, frame):  # the openni driver's defaults, not TUM's calibration
        roi = T["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
        k = np.array([525.0, 0, 319.5, 0, 525.0, 239.5, 0, 0, 1])
        return T["sensor_msgs/msg/CameraInfo"](
            header=header(ns, frame), height=480, width=640, distortion_model="plumb_bob", D=np.zeros(5), K=k,
            R=np.eye(3).reshape(-1), P=np.array([525.0, 0, 319.5, 0, 0, 525.0, 239.5, 0, 0, 0, 1, 0]), binning_x=0,
            binning_y=0, roi=roi)

    def transform(ns, parent, child, xyz, yaw):
        return T["geometry_msgs/msg/TransformStamped"](
            header=header(ns, parent), child_frame_id=child,
            transform=T["geometry_msgs/msg/Transform"](
                translation=T["geometry_msgs/msg/Vector3"](x=xyz[0], y=xyz[1], z=xyz[2]),
                rotation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))))

    def tf(ns, transforms):
        return (ns, "/tf", "tf/msg/tfMessage", T["tf/msg/tfMessage"](transforms=transforms))

    messages = []
    for i, f in enumerate(line.split(",") for line in (src / "frames.csv").read_text().split("\n") if line):
        ns = int(f[0])
        bgr, mm = np.load(src / f[1]), np.load(src / f[2])
        bgr = np.dstack([bgr] * 3) if bgr.ndim == 2 else bgr  # the Kinect's camera is a colour one
        messages.append((ns, "/camera/rgb/image_color", "sensor_msgs/msg/Image",
                         image(ns, bgr[:, :, ::-1], "rgb8", "/openni_rgb_optical_frame")))
        messages.append((ns, "/camera/rgb/camera_info", "sensor_msgs/msg/CameraInfo",
                         info(ns, "/openni_rgb_optical_frame")))
        metres = np.where(mm > 0, mm.astype(np.float32) / 1000, np.nan).astype(np.float32)
        messages.append((ns, "/camera/depth/image", "sensor_msgs/msg/Image",
                         image(ns, metres, "32FC1", "/openni_depth_optical_frame")))
        messages.append((ns, "/camera/depth/camera_info", "sensor_msgs/msg/CameraInfo",
                         info(ns, "/openni_depth_optical_frame")))
        messages.append(tf(ns, [transform(ns, "/world", "/kinect", (0.01 * i, 0.0, 1.2), 0.002 * i),
                                transform(ns, "/kinect", "/openni_camera", (0.0, 0.0, 0.0), 0.0),
                                transform(ns, "/openni_camera", "/openni_rgb_frame", (0.0, -0.02, 0.0), 0.0),
                                transform(ns, "/openni_rgb_frame", "/openni_rgb_optical_frame", (0.0, 0.0, 0.0),
                                          0.0)]))
    for o in (line.split(",") for line in (src / "odometry.csv").read_text().split("\n") if line):
        ns, (x, y, theta) = int(o[0]), (float(v) for v in o[1:4])
        pose = T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
                                           orientation=T["geometry_msgs/msg/Quaternion"](
                                               x=0.0, y=0.0, z=math.sin(theta / 2), w=math.cos(theta / 2)))
        zero = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
        messages.append((ns, "/pose", "nav_msgs/msg/Odometry", T["nav_msgs/msg/Odometry"](
            header=header(ns, "odom"), child_frame_id="base_link",
            pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](linear=zero, angular=zero), covariance=np.zeros(36)))))
        messages.append(tf(ns, [transform(ns, "/odom", "/base_link", (x, y, 0.0), theta)]))
    write(a, ts, messages)


if __name__ == "__main__":
    main()
