# Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
"""Writes a ROS bag from a simulated sequence dumped by bag_test (with the rosbags writer).

  write_bag.py SRC BAG --storage ros1|sqlite3|mcap --odometry odometry|joints|speeds|twist [--wheels R,B]
               [--drop TOPIC] [--encoding ENC] [--swap N]

The last three spoil the bag for the bad-input tests: a topic left out, the camera's images
labelled with another encoding, the header stamps of frames N and N + 1 swapped.

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
    a = p.parse_args()
    src = Path(a.src)
    ros1 = a.storage == "ros1"
    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if ros1:  # ROS 1's tf2_msgs is not in rosbags' noetic store: its definition, as ROS 1 has it
        ts.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"))
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
    messages.sort(key=lambda m: m[0])

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


if __name__ == "__main__":
    main()
