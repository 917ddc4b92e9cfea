# Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
"""rvwo-bag: a ROS 1 bag or a ROS 2 bag (sqlite3 or mcap) to an RVWO rawlog and settings.yaml.

No ROS is needed: the bag is read with the rosbags package (pinned in
scripts/python-requirements.txt). The camera's images are written as PNG files (compressed ones as
they came) with the lists and odometry.csv of rvwo-convert's generic folder, then rvwo-convert
makes the rawlog. CameraInfo gives the camera's keys of the settings, /tf_static (or /tf) the
camera-to-base transform; the last line names what the user must still supply.

  rvwo-bag --in run.bag --list
  rvwo-bag --in run.bag --out run/ --image /cam/left/image_raw --right /cam/right/image_raw
"""
import argparse
import math
import os
import shutil
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.rosbag1 import ReaderError as ReaderError1
from rosbags.rosbag2 import ReaderError as ReaderError2

IMAGE = "sensor_msgs/msg/Image"
COMPRESSED = "sensor_msgs/msg/CompressedImage"
INFO = "sensor_msgs/msg/CameraInfo"
ODOMETRY = "nav_msgs/msg/Odometry"
JOINTS = "sensor_msgs/msg/JointState"
TWIST = "geometry_msgs/msg/TwistStamped"
TF = ("tf2_msgs/msg/TFMessage", "tf/msg/tfMessage")  # ROS 2 and ROS 1's; the older tf's, as TUM's bags have it
ODOMETRY_TYPES = (ODOMETRY, JOINTS, TWIST)
TICKS_PER_REVOLUTION = 65536  # rvwo-convert's wheel angles as encoder ticks (a power of two: exact)
# TUM RGB-D's bags (Sturm et al., IROS 2012, "File Formats"): the Kinect's colour and registered depth (32FC1, m),
# and on the fr2 Pioneer sequences the robot's odometry, published by its driver as nav_msgs/Odometry on /pose.
TUM_TOPICS = {"image": "/camera/rgb/image_color", "depth": "/camera/depth/image", "odometry": "/pose"}
TUM_PRESETS = ("fr1", "fr2", "fr3")
# The keys of the camera itself, which a preset writes (rvwo-convert, apps/convert/presets.cc).
CAMERA_KEYS = ("Camera.type:", "Camera1.", "Camera.width:", "Camera.height:", "Camera.fps:")


class BagError(Exception):
    """One line for the user: what is wrong and where."""


def stamp(msg):
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


# camera_info distortion models: ROS's (sensor_msgs/distortion_models.h), and the name the RealSense
# SDK gives the T265's fisheyes, which its ROS driver has published as it is.
PINHOLE_MODELS = ("plumb_bob", "rational_polynomial", "")
FISHEYE_MODELS = ("equidistant", "kannala brandt4", "fisheye")


def distortion_of(info, topic):
    """A CameraInfo's distortion as RVWO takes it: (fisheye, coefficients), Kannala-Brandt k1..k4 or
    radial-tangential k1, k2, p1, p2, k3; a model RVWO cannot hold whole is refused, never cut."""
    d = [float(v) for v in (info.d if hasattr(info, "d") else info.D)]
    model = info.distortion_model
    if model.lower() in FISHEYE_MODELS:
        if any(d[4:]):
            raise BagError(f"{topic}: camera_info's {model} distortion has {len(d)} coefficients; RVWO's fisheye "
                           "(KannalaBrandt8) takes k1..k4")
        return True, (d + [0.0] * 4)[:4]
    if model not in PINHOLE_MODELS:
        raise BagError(f"{topic}: camera_info distortion model '{model}' is not plumb_bob, rational_polynomial "
                       "or equidistant")
    if any(d[5:]):
        raise BagError(f"{topic}: camera_info's {model} distortion has k4..k6; RVWO's pinhole takes k1, k2, p1, p2, "
                       "k3: calibrate with plumb_bob")
    return False, (d + [0.0] * 5)[:5]


def mounts(published, tolerance=1e-9):
    """The transforms (TransformStamped) that stay put over the bag, by (parent, child) frame without a leading
    slash. One that changes (a driver's odom -> base_link, a motion capture's) is a motion, not a mount: a chain
    through it would give the camera's place at one instant. Alike: within `tolerance` (m, quaternion components)."""
    def numbers(tr):
        t, q = tr.translation, tr.rotation
        return (t.x, t.y, t.z, q.x, q.y, q.z, q.w)
    first, moving = {}, set()
    for tr in published:
        key = (tr.header.frame_id.lstrip("/"), tr.child_frame_id.lstrip("/"))
        if key in first and any(abs(a - b) > tolerance for a, b in zip(numbers(first[key]), numbers(tr.transform))):
            moving.add(key)
        first.setdefault(key, tr.transform)
    return {key: tr for key, tr in first.items() if key not in moving}


def png(path, pixels):
    """Writes an 8-bit grey or RGB, or a 16-bit grey, image as PNG (filter 0 on every row)."""
    pixels = np.ascontiguousarray(pixels)
    height, width = pixels.shape[:2]
    channels = 1 if pixels.ndim == 2 else pixels.shape[2]
    depth = 16 if pixels.dtype == np.uint16 else 8
    colour = {1: 0, 3: 2}[channels]
    rows = pixels.astype(">u2" if depth == 16 else np.uint8).reshape(height, -1).view(np.uint8)
    raw = np.hstack([np.zeros((height, 1), np.uint8), rows]).tobytes()

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", width, height, depth, colour, 0, 0, 0)
    Path(path).write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 1)) +
                           chunk(b"IEND", b""))


def pixels_of(msg, topic, index, depth):
    """An Image message's pixels: 8-bit grey or RGB, or 16-bit depth in millimetres."""
    enc = msg.encoding.lower()
    data = np.frombuffer(msg.data, np.uint8).reshape(msg.height, msg.step)
    if enc in ("mono8", "8uc1"):
        return data[:, :msg.width]
    if enc in ("rgb8", "bgr8", "rgba8", "bgra8"):
        n = 4 if enc.endswith("a8") else 3
        rgb = data[:, :msg.width * n].reshape(msg.height, msg.width, n)[:, :, :3]
        return rgb[:, :, ::-1] if enc.startswith("bgr") else rgb
    if enc in ("mono16", "16uc1"):
        return data[:, :msg.width * 2].view(">u2" if msg.is_bigendian else "<u2").astype(np.uint16)
    if enc == "32fc1" and depth:
        metres = data[:, :msg.width * 4].view(">f4" if msg.is_bigendian else "<f4")
        mm = np.where(np.isfinite(metres) & (metres > 0), np.round(metres * 1000), 0)
        return np.clip(mm, 0, 65535).astype(np.uint16)
    raise BagError(f"{topic} message {index}: image encoding '{msg.encoding}' is not one RVWO reads "
                   "(mono8, rgb8, bgr8, rgba8, bgra8, mono16, 16UC1; 32FC1 for depth)")


class Conversion:
    """One bag to one folder: the images, their lists, odometry.csv and settings.yaml."""

    def __init__(self, args):
        self.args = args
        self.out = Path(args.out)
        self.still = []  # what the user must still supply
        self.info = {}   # role -> CameraInfo
        self.frame_of = {}  # role -> the images' frame_id
        self.joint_kind = None  # JointState: "angles" or "speeds"

    def run(self, reader):
        roles = self.pick_topics(reader)
        self.out.mkdir(parents=True, exist_ok=True)
        rows = {role: [] for role in roles if role != "odometry"}
        odometry = []
        conns = [c for c in reader.connections if c.topic in roles.values() or c.msgtype == INFO or c.msgtype in TF]
        role_of = {topic: role for role, topic in roles.items()}
        published = []  # every geometry_msgs/TransformStamped of /tf and /tf_static
        counts = {}
        for conn, _, raw in reader.messages(connections=conns):
            msg = reader.deserialize(raw, conn.msgtype)
            role = role_of.get(conn.topic)
            index = counts[conn.topic] = counts.get(conn.topic, 0) + 1
            if conn.msgtype in TF:
                published += msg.transforms
            elif conn.msgtype == INFO:
                self.info.setdefault(conn.topic, msg)
            elif role == "odometry":
                odometry.append(self.odometry_row(msg, conn.topic, index))
            elif role is not None:
                rows[role].append(self.image(msg, conn, role, index))
        for role, r in rows.items():
            self.check_order(r, roles[role])
        if odometry:
            self.check_order(odometry, roles["odometry"])
        self.write_lists(rows, odometry)
        self.write_settings(roles, rows, mounts(published))
        return rows, odometry

    def pick_topics(self, reader):
        topics = {c.topic: c.msgtype for c in reader.connections}
        images = sorted(t for t, ty in topics.items() if ty in (IMAGE, COMPRESSED))

        def named(flag, value, types, what):
            if value is None:
                return None
            if value not in topics:
                raise BagError(f"{self.args.input}: no topic {value} ({flag}); --list shows the bag's topics")
            if topics[value] not in types:
                raise BagError(f"{self.args.input}: topic {value} is {topics[value]}, not {what} ({flag})")
            return value

        roles = {}
        if self.args.preset:  # a TUM bag: its own topic names unless the flags give others
            self.args.image = self.args.image or TUM_TOPICS["image"]
            self.args.depth = self.args.depth or TUM_TOPICS["depth"]
            if not self.args.odometry and TUM_TOPICS["odometry"] not in topics:
                self.args.no_odometry = True
                self.still.append(f"wheel odometry: this bag has no {TUM_TOPICS['odometry']} (of TUM's, only the fr2 "
                                  "pioneer_* sequences do): replay with --mode vo")
            self.args.odometry = self.args.odometry or TUM_TOPICS["odometry"]
        image = named("--image", self.args.image, (IMAGE, COMPRESSED), "an image")
        if image is None:
            if not images:
                raise BagError(f"{self.args.input}: no camera topic (sensor_msgs/Image or CompressedImage)")
            if len(images) > 1:
                raise BagError(f"{self.args.input}: {len(images)} image topics ({', '.join(images)}): choose the "
                               "camera with --image (and --right or --depth)")
            image = images[0]
        roles["left"] = image
        if self.args.right:
            roles["right"] = named("--right", self.args.right, (IMAGE, COMPRESSED), "an image")
        if self.args.depth:
            roles["depth"] = named("--depth", self.args.depth, (IMAGE, COMPRESSED), "an image")
        if self.args.no_odometry:
            return roles
        odometry = named("--odometry", self.args.odometry, ODOMETRY_TYPES,
                         "nav_msgs/Odometry, sensor_msgs/JointState or geometry_msgs/TwistStamped")
        if odometry is None:
            found = sorted(t for t, ty in topics.items() if ty in ODOMETRY_TYPES)
            if len(found) != 1:
                raise BagError(f"{self.args.input}: " + (f"{len(found)} odometry topics ({', '.join(found)}): choose "
                                                           "one with --odometry" if found else
                                                           "no odometry topic (nav_msgs/Odometry, sensor_msgs/"
                                                           "JointState, geometry_msgs/TwistStamped): name one with "
                                                           "--odometry, or give --no-odometry for --mode vo"))
            odometry = found[0]
        roles["odometry"] = odometry
        self.odometry_type = topics[odometry]
        return roles

    def image(self, msg, conn, role, index):
        t = stamp(msg)
        self.frame_of.setdefault(role, msg.header.frame_id.lstrip("/"))
        folder = self.out / "images" / role
        folder.mkdir(parents=True, exist_ok=True)
        name = f"{msg.header.stamp.sec}.{msg.header.stamp.nanosec:09d}"
        if conn.msgtype == COMPRESSED:
            fmt = msg.format.lower()
            data = bytes(msg.data)
            if "compresseddepth" in fmt:
                data = data[12:]  # the compressedDepth header before the PNG
            ext = ".png" if "png" in fmt else ".jpg" if ("jpeg" in fmt or "jpg" in fmt) else None
            if ext is None:
                raise BagError(f"{conn.topic} message {index}: compressed format '{msg.format}' is not png or jpeg")
            path = folder / (name + ext)
            path.write_bytes(data)
        else:
            path = folder / (name + ".png")
            png(path, pixels_of(msg, conn.topic, index, role == "depth"))
        return (t, path.relative_to(self.out).as_posix(), conn.topic, index)

    def odometry_row(self, msg, topic, index):
        t = stamp(msg)
        if self.odometry_type == ODOMETRY:
            q = msg.pose.pose.orientation
            yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
            p = msg.pose.pose.position
            return (t, p.x, p.y, yaw, topic, index)
        if self.odometry_type == TWIST:
            return (t, msg.twist.linear.x, msg.twist.angular.z, topic, index)
        names = list(msg.name)
        left, right = self.args.left_joint, self.args.right_joint
        if left not in names or right not in names:
            raise BagError(f"{topic} message {index}: no joints '{left}' and '{right}' (it has {', '.join(names)}): "
                           "name the wheels with --left-joint and --right-joint")
        i, j = names.index(left), names.index(right)
        if self.joint_kind is None:  # angles when the messages carry them, else speeds
            self.joint_kind = "angles" if len(msg.position) == len(names) else "speeds"
        if self.joint_kind == "angles":
            if len(msg.position) != len(names):
                raise BagError(f"{topic} message {index}: no wheel angles (position), as the messages before had")
            return (t, msg.position[i], msg.position[j], topic, index)
        if len(msg.velocity) != len(names):
            raise BagError(f"{topic} message {index}: neither wheel angles (position) nor speeds (velocity)")
        r, b = self.args.wheel_radius, self.args.track
        if r is None or b is None:
            raise BagError(f"{topic}: the JointState gives wheel speeds only: give --wheel-radius and --track, which "
                           "turn them into the robot's speed and turn rate")
        wl, wr = msg.velocity[i], msg.velocity[j]
        return (t, r * (wl + wr) / 2, r * (wr - wl) / b, topic, index)

    @staticmethod
    def check_order(rows, topic):
        for a, b in zip(rows, rows[1:]):
            if not b[0] > a[0]:
                raise BagError(f"{topic} message {b[-1]}: its stamp {b[0]:.9f} s is not after the one before "
                               f"({a[0]:.9f} s): the bag's stamps go backwards or repeat")

    def write_lists(self, rows, odometry):
        names = {"left": "images.txt", "right": "images_right.txt", "depth": "depth.txt"}
        for role, r in rows.items():
            with open(self.out / names[role], "w") as f:
                f.writelines(f"{t:.9f} {path}\n" for t, path, *_ in r)
        header = {ODOMETRY: "t,x,y,theta", JOINTS: "t,left_angle,right_angle", TWIST: "t,v,omega"}
        if self.joint_kind == "speeds":
            header[JOINTS] = "t,v,omega"
        if odometry:
            with open(self.out / "odometry.csv", "w") as f:
                f.write(header[self.odometry_type] + "\n")
                f.writelines(",".join(repr(float(v)) for v in row[:-2]) + "\n" for row in odometry)

    def camera_info(self, role, topic):
        """The CameraInfo beside an image topic (/cam/left/image_raw -> /cam/left/camera_info)."""
        base = topic[:-len("/compressed")] if topic.endswith("/compressed") else topic
        for candidate in (base.rsplit("/", 1)[0] + "/camera_info", base + "/camera_info"):
            if candidate in self.info:
                return self.info[candidate]
        self.still.append(f"the {role} camera's intrinsics (no camera_info beside {topic})")
        return None

    def base_to_camera(self, transforms, camera):
        """T_b_c from the bag's transforms (any chain of them, either way round), or None."""
        def matrix(tr):
            x, y, z, w = tr.rotation.x, tr.rotation.y, tr.rotation.z, tr.rotation.w
            m = np.eye(4)
            m[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                         [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                         [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
            m[:3, 3] = [tr.translation.x, tr.translation.y, tr.translation.z]
            return m
        edges = {}
        for (parent, child), tr in transforms.items():
            edges.setdefault(parent, []).append((child, matrix(tr)))
            edges.setdefault(child, []).append((parent, np.linalg.inv(matrix(tr))))
        seen, todo = {self.args.base_frame}, [(self.args.base_frame, np.eye(4))]
        while todo:
            frame, T = todo.pop()
            if frame == camera:
                return T
            for nxt, step in edges.get(frame, []):
                if nxt not in seen:
                    seen.add(nxt)
                    todo.append((nxt, T @ step))
        return None

    def write_settings(self, roles, rows, transforms):
        lines = ["%YAML:1.0", f"# written by rvwo-bag from {Path(self.args.input).name}"]
        sensor = "stereo" if "right" in roles else "rgbd" if "depth" in roles else "mono"
        lines.append(f'Sensor: "{sensor}"')
        # With a preset, its camera (use_preset_camera), whatever the bag's camera_info says.
        info = None if self.args.preset else self.camera_info("left", roles["left"])
        if info is not None:
            k = list(getattr(info, "k", None) if hasattr(info, "k") else info.K)
            fisheye, d = distortion_of(info, roles["left"])
            lines += [f'Camera.type: "{"KannalaBrandt8" if fisheye else "PinHole"}"',
                      f"Camera1.fx: {float(k[0])!r}", f"Camera1.fy: {float(k[4])!r}", f"Camera1.cx: {float(k[2])!r}",
                      f"Camera1.cy: {float(k[5])!r}"]
            keys = ["k1", "k2", "k3", "k4"] if fisheye else ["k1", "k2", "p1", "p2", "k3"]
            lines += [f"Camera1.{key}: {d[i]!r}" for i, key in enumerate(keys)]
            lines += [f"Camera.width: {info.width}", f"Camera.height: {info.height}"]
        times = np.array([r[0] for r in rows["left"]])
        if len(times) > 1:
            lines.append(f"Camera.fps: {round(1 / float(np.median(np.diff(times))), 3)!r}")
        else:
            self.still.append("Camera.fps (one frame only)")
        if "right" in roles:
            right = self.camera_info("right", roles["right"])
            if right is not None:
                p = list(right.p if hasattr(right, "p") else right.P)
                if not p[3] < 0:
                    self.still.append("Stereo.b (the right camera_info's P gives no baseline)")
                else:
                    lines.append(f"Stereo.b: {float(-p[3] / p[0])!r}")
        if "depth" in roles:
            lines.append("RGBD.DepthMapFactor: 1000.0  # the depth images are written in millimetres")
        T = self.base_to_camera(transforms, self.frame_of.get("left", ""))
        if T is None and not self.args.preset:  # (a preset has one: use_preset_camera)
            self.still.append(f"Camera.T_b_c (no transform from {self.args.base_frame} to the camera's frame "
                              f"'{self.frame_of.get('left', '')}' in /tf_static or /tf; --base-frame names the base)")
        elif T is not None:
            data = ", ".join(repr(float(v)) for v in T.reshape(-1))
            lines += ["Camera.T_b_c: !!opencv-matrix", "   rows: 4", "   cols: 4", "   dt: d", f"   data: [{data}]"]
        if "odometry" in roles:
            source = {ODOMETRY: "pose", JOINTS: "encoders", TWIST: "velocities"}[self.odometry_type]
            if self.joint_kind == "speeds":
                source = "velocities"
            lines.append(f'Odometry.Input: "{source}"  # from {roles["odometry"]}')
            if source == "encoders":
                lines.append(f"Odometry.TicksPerRevolution: {TICKS_PER_REVOLUTION}  # the wheel angles, as ticks")
            if self.args.wheel_radius is None or self.args.track is None:
                self.still.append("Odometry.WheelRadiusLeft, Odometry.WheelRadiusRight and Odometry.Track (m; or "
                                  "--wheel-radius and --track)")
            else:
                lines += [f"Odometry.WheelRadiusLeft: {self.args.wheel_radius!r}",
                          f"Odometry.WheelRadiusRight: {self.args.wheel_radius!r}", f"Odometry.Track: {self.args.track!r}"]
        lines.append('Semantics.LabelSet: "voc21"')
        self.lines = lines
        (self.out / "settings.yaml").write_text("\n".join(lines) + "\n")

    def use_preset_camera(self, settings):
        """Puts the camera of a preset's settings file (what rvwo-convert --preset wrote there) in place of the
        bag's CameraInfo, keeping the rest (depth, odometry, Camera.T_b_c from the bag); writes it back whole."""
        preset = settings.read_text().splitlines()
        camera = [line for line in preset if line.startswith(CAMERA_KEYS)]
        if not camera:
            raise BagError(f"{settings}: rvwo-convert wrote no camera for --preset {self.args.preset}")
        rest = [line for line in self.lines if not line.startswith(CAMERA_KEYS)]  # the bag's fps, say
        if not any(line.startswith("Camera.T_b_c:") for line in rest):  # the preset's: the base at the camera
            at = next(i for i, line in enumerate(preset) if line.startswith("Camera.T_b_c:"))
            camera += preset[at:at + 5]  # the key, rows, cols, dt, data
            if any(line.startswith("Odometry.Input:") for line in rest):
                self.still.append("Camera.T_b_c: the Kinect on the robot's base (TUM published none; the settings "
                                  "put the base at the camera, x forward, which --mode vw needs measured)")
        at = next(i for i, line in enumerate(rest) if line.startswith("Sensor:")) + 1
        text = "\n".join(rest[:at] + [f"# camera: TUM RGB-D's published calibration (rvwo-convert --preset "
                                        f"{self.args.preset})"] + camera + rest[at:]) + "\n"
        staged = settings.with_name(settings.name + ".partial")
        staged.write_text(text)
        staged.replace(settings)


def list_topics(reader):
    """Each topic's type, message count and mean rate over the bag's span (read from its index)."""
    span = (reader.end_time - reader.start_time) * 1e-9
    print(f"{'topic':40s} {'type':36s} {'messages':>8s} {'rate':>9s}")
    for topic, info in sorted(reader.topics.items()):
        rate = f"{(info.msgcount - 1) / span:.1f} Hz" if span > 0 and info.msgcount > 1 else "-"
        print(f"{topic:40s} {info.msgtype:36s} {info.msgcount:8d} {rate:>9s}")


def convert_tool():
    """rvwo-convert: beside this program (installed, or the build's), else on the PATH."""
    for d in (os.environ.get("RVWO_BIN_DIR"), str(Path(sys.argv[0]).resolve().parent)):
        if d and (Path(d) / "rvwo-convert").is_file():
            return str(Path(d) / "rvwo-convert")
    return "rvwo-convert"


class Parser(argparse.ArgumentParser):
    """As RVWO's other apps: "USAGE:" in --help, one error line and exit 1 for a bad command line."""

    def error(self, message):
        print(f"rvwo-bag: error: {message}", file=sys.stderr)
        sys.exit(1)

    def format_usage(self):
        return super().format_usage().replace("usage: ", "USAGE: ", 1)

    def format_help(self):
        return super().format_help().replace("usage: ", "USAGE: ", 1)


def arguments():
    p = Parser(prog="rvwo-bag", description=(
        "A ROS 1 bag or a ROS 2 bag (sqlite3 or mcap) to an RVWO rawlog and settings.yaml, without ROS: the "
        "camera's images (Image or CompressedImage), CameraInfo, odometry (Odometry, JointState wheel angles or "
        "TwistStamped) and the camera-to-base transform (/tf_static)."))
    p.add_argument("--in", dest="input", metavar="BAG", help="the bag: a .bag file or a ROS 2 bag folder (required)")
    p.add_argument("--list", action="store_true", help="print the bag's topics, types, counts and rates, and stop")
    p.add_argument("--out", metavar="DIR", help="the folder to make: images, sequence.rawlog, settings.yaml")
    p.add_argument("--image", metavar="TOPIC", help="the camera (the left one of a pair); default: the only image topic")
    p.add_argument("--right", metavar="TOPIC", help="the right camera of a rectified stereo pair")
    p.add_argument("--depth", metavar="TOPIC", help="depth registered to --image (16UC1 mm, 32FC1 m)")
    p.add_argument("--odometry", metavar="TOPIC", help="Odometry, JointState or TwistStamped; default: the only one")
    p.add_argument("--no-odometry", action="store_true", help="no odometry: for rvwo-replay --mode vo")
    p.add_argument("--left-joint", default="left_wheel_joint", help="JointState: the left wheel's name")
    p.add_argument("--right-joint", default="right_wheel_joint", help="JointState: the right wheel's name")
    p.add_argument("--wheel-radius", type=float, metavar="M", help="the wheels' radius, m (into the settings)")
    p.add_argument("--track", type=float, metavar="M", help="the distance between the wheels, m (into the settings)")
    p.add_argument("--base-frame", default="base_link", help="the robot's base frame in /tf_static (base_link)")
    p.add_argument("--preset", choices=TUM_PRESETS, help="a TUM RGB-D bag of this rig: its topics (/camera/rgb/"
                   "image_color, /camera/depth/image, /pose) and its published camera (rvwo-convert's presets)")
    p.add_argument("--version", action="version", version=f"rvwo-bag  version: {os.environ.get('RVWO_VERSION', '?')}")
    args = p.parse_args()
    if not args.input:
        p.error("--in BAG is needed")
    for name, value in (("--wheel-radius", args.wheel_radius), ("--track", args.track)):
        if value is not None and not (value > 0 and math.isfinite(value)):
            p.error(f"{name} must be a length > 0 in metres, not {value}")
    return args


def main():
    args = arguments()
    if not Path(args.input).exists():
        print(f"rvwo-bag: error: {args.input}: not found (a ROS 1 .bag file or a ROS 2 bag folder)", file=sys.stderr)
        return 1
    try:
        with AnyReader([Path(args.input)]) as reader:
            if args.list:
                list_topics(reader)
                return 0
            if not args.out:
                raise BagError("--out DIR is needed (or --list)")
            out = Path(args.out)
            if out.exists() and (not out.is_dir() or any(out.iterdir())):
                raise BagError(f"--out {out}: exists and is not an empty folder: give a new one")
            staged = out.parent / f".{out.name}.partial"
            shutil.rmtree(staged, ignore_errors=True)  # a run interrupted before
            args.out = str(staged)
            conversion = Conversion(args)
            try:
                rows, odometry = conversion.run(reader)
            except BaseException:
                shutil.rmtree(staged, ignore_errors=True)
                raise
    except (AnyReaderError, ReaderError1, ReaderError2, EOFError, struct.error) as e:
        detail = " ".join(str(e).split())
        print(f"rvwo-bag: error: {args.input}: cannot be read: cut short or damaged, or not a bag (rosbags: {detail}); "
              "copy it again from its source", file=sys.stderr)
        return 1
    except BagError as e:
        print(f"rvwo-bag: error: {e}", file=sys.stderr)
        return 1
    if out.exists():
        out.rmdir()
    staged.rename(out)
    preset = ["--preset", args.preset] if args.preset else []
    done = subprocess.run([convert_tool(), "generic", "--in", str(out), "--out", str(out / "sequence.rawlog"),
                           "--depth-factor", "1000"] + preset, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        if done.returncode != 0:
            raise BagError(f"{done.stderr.strip() or 'rvwo-convert failed'} (nothing written)")
        if args.preset:  # rvwo-convert wrote the preset's settings: the bag's own, with the preset's camera
            conversion.use_preset_camera(out / "settings.yaml")
    except BagError as e:
        shutil.rmtree(out, ignore_errors=True)
        print(f"rvwo-bag: error: {e}", file=sys.stderr)
        return 1
    print(f"rvwo-bag: {args.input}: {len(rows['left'])} frames, {len(odometry)} odometry readings -> "
          f"{out / 'sequence.rawlog'} and {out / 'settings.yaml'}")
    if conversion.still:
        print("rvwo-bag: still to supply in settings.yaml: " + "; ".join(conversion.still))
    return 0


if __name__ == "__main__":
    sys.exit(main())
