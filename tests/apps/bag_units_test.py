# Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
"""rvwo-bag's pieces on their own: each image encoding it reads, to the pixels RVWO's apps decode
(its PNG writer read back by an independent decoder: zlib and the PNG layout), and the
transform chain it walks in /tf_static, which leaves out the transforms that move, and the camera
distortions it takes.

  python tests/apps/bag_units_test.py     (ctest: bag_units, with the set-up's Python)
"""
import struct
import sys
import types
import unittest
import zlib
from pathlib import Path
from tempfile import TemporaryDirectory

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "apps"))
import rvwo_bag  # noqa: E402


def read_png(path):
    """8-bit grey or RGB, or 16-bit grey; filter 0 rows only (what rvwo_bag.png writes)."""
    data = Path(path).read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, ihdr = 8, b"", None
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        assert struct.unpack(">I", data[pos + 8 + n:pos + 12 + n])[0] == zlib.crc32(kind + body) & 0xFFFFFFFF
        if kind == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    width, height, depth, colour = ihdr[:4]
    channels = {0: 1, 2: 3}[colour]
    rows = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(height, -1)
    assert (rows[:, 0] == 0).all()
    dtype = ">u2" if depth == 16 else np.uint8
    img = rows[:, 1:].copy().view(dtype).astype(np.uint16 if depth == 16 else np.uint8)
    return img.reshape(height, width) if channels == 1 else img.reshape(height, width, 3)


def message(encoding, array, big=False):
    raw = np.ascontiguousarray(array)
    if big:
        raw = raw.astype(raw.dtype.newbyteorder(">"))
    height = array.shape[0]
    data = raw.view(np.uint8).reshape(height, -1)
    padded = np.hstack([data, np.zeros((height, 3), np.uint8)])  # a row step longer than the pixels
    return types.SimpleNamespace(encoding=encoding, height=height, width=array.shape[1], step=padded.shape[1],
                                 is_bigendian=int(big), data=padded.reshape(-1))


class Encodings(unittest.TestCase):
    def setUp(self):
        rng = np.random.default_rng(7)
        self.rgb = rng.integers(0, 256, (5, 7, 3), dtype=np.uint8)
        self.grey = rng.integers(0, 256, (5, 7), dtype=np.uint8)
        self.depth = rng.integers(0, 65536, (5, 7), dtype=np.uint16)
        self.dir = TemporaryDirectory()

    def tearDown(self):
        self.dir.cleanup()

    def through_png(self, msg, depth=False):
        path = Path(self.dir.name) / "x.png"
        rvwo_bag.png(path, rvwo_bag.pixels_of(msg, "/t", 1, depth))
        return read_png(path)

    def test_colour_orders_end_as_rgb(self):
        np.testing.assert_array_equal(self.through_png(message("rgb8", self.rgb)), self.rgb)
        np.testing.assert_array_equal(self.through_png(message("bgr8", self.rgb[:, :, ::-1])), self.rgb)
        rgba = np.dstack([self.rgb, np.full((5, 7), 9, np.uint8)])
        np.testing.assert_array_equal(self.through_png(message("rgba8", rgba)), self.rgb)
        bgra = np.dstack([self.rgb[:, :, ::-1], np.full((5, 7), 9, np.uint8)])
        np.testing.assert_array_equal(self.through_png(message("bgra8", bgra)), self.rgb)

    def test_grey_and_sixteen_bit_either_byte_order(self):
        np.testing.assert_array_equal(self.through_png(message("mono8", self.grey)), self.grey)
        np.testing.assert_array_equal(self.through_png(message("16UC1", self.depth)), self.depth)
        np.testing.assert_array_equal(self.through_png(message("mono16", self.depth, big=True)), self.depth)

    def test_metres_become_millimetres_and_holes_zero(self):
        metres = np.array([[0.5, 1.2344, np.nan], [-1.0, 70.0, 0.0]], np.float32)
        got = self.through_png(message("32FC1", metres), depth=True)
        np.testing.assert_array_equal(got, [[500, 1234, 0], [0, 65535, 0]])

    def test_unknown_encoding_names_topic_and_message(self):
        with self.assertRaisesRegex(rvwo_bag.BagError, r"^/t message 1: image encoding 'yuv422' is not one"):
            rvwo_bag.pixels_of(message("yuv422", self.grey), "/t", 1, False)
        with self.assertRaises(rvwo_bag.BagError):  # metres are depth only
            rvwo_bag.pixels_of(message("32FC1", np.zeros((2, 2), np.float32)), "/t", 1, False)


class Distortion(unittest.TestCase):
    @staticmethod
    def info(model, d):
        return types.SimpleNamespace(distortion_model=model, d=d)

    def test_fisheye_names_and_radial_tangential(self):
        # ROS's equidistant, and the RealSense SDK's name for the T265's, as its ROS driver published it.
        for model in ("equidistant", "Kannala Brandt4"):
            self.assertEqual(rvwo_bag.distortion_of(self.info(model, [0.1, 0.2, 0.3, 0.4, 0.0]), "/t"),
                             (True, [0.1, 0.2, 0.3, 0.4]))
        self.assertEqual(rvwo_bag.distortion_of(self.info("plumb_bob", [0.1, 0.2, 0.01, 0.02]), "/t"),
                         (False, [0.1, 0.2, 0.01, 0.02, 0.0]))
        self.assertEqual(rvwo_bag.distortion_of(self.info("rational_polynomial", [0.1, 0, 0, 0, 0.3, 0, 0, 0]), "/t"),
                         (False, [0.1, 0, 0, 0, 0.3]))

    def test_what_rvwo_cannot_hold_is_refused_not_cut(self):
        with self.assertRaisesRegex(rvwo_bag.BagError, r"^/t: camera_info's rational_polynomial distortion has "
                                                        r"k4..k6"):
            rvwo_bag.distortion_of(self.info("rational_polynomial", [0.1, 0, 0, 0, 0.3, 0.05, 0, 0]), "/t")
        with self.assertRaisesRegex(rvwo_bag.BagError, r"^/t: camera_info distortion model 'pinhole_x' is not"):
            rvwo_bag.distortion_of(self.info("pinhole_x", []), "/t")


class Transforms(unittest.TestCase):
    @staticmethod
    def transform(xyz, quaternion):
        v = types.SimpleNamespace
        return v(translation=v(x=xyz[0], y=xyz[1], z=xyz[2]),
                 rotation=v(x=quaternion[0], y=quaternion[1], z=quaternion[2], w=quaternion[3]))

    def test_chain_either_way_round(self):
        # base_link -> mount (1 m ahead, turned 90 deg about z); camera -> mount given the other way.
        s = np.sqrt(0.5)
        transforms = {("base_link", "mount"): self.transform((1, 0, 0), (0, 0, s, s)),
                      ("camera", "mount"): self.transform((0, 0, -0.5), (0, 0, 0, 1))}
        conv = rvwo_bag.Conversion(types.SimpleNamespace(out="x", base_frame="base_link"))
        T = conv.base_to_camera(transforms, "camera")
        expected = np.array([[0, -1, 0, 1], [1, 0, 0, 0], [0, 0, 1, 0.5], [0, 0, 0, 1]], float)
        np.testing.assert_allclose(T, expected, atol=1e-15)
        self.assertIsNone(conv.base_to_camera(transforms, "elsewhere"))

    def test_a_transform_that_moves_is_no_mount(self):
        # odom -> base_link moves with the robot; /kinect -> /camera stays put (leading slashes as ROS 1 had them).
        v = types.SimpleNamespace

        def stamped(parent, child, x):
            return v(header=v(frame_id=parent), child_frame_id=child, transform=self.transform((x, 0, 0), (0, 0, 0, 1)))
        published = [stamped("/odom", "/base_link", 0.0), stamped("/kinect", "/camera", 0.1),
                     stamped("/odom", "/base_link", 0.5), stamped("/kinect", "/camera", 0.1 + 1e-12)]
        kept = rvwo_bag.mounts(published)
        self.assertEqual(sorted(kept), [("kinect", "camera")])
        self.assertEqual(kept[("kinect", "camera")].translation.x, 0.1)  # the first, to within 1e-9
        conv = rvwo_bag.Conversion(types.SimpleNamespace(out="x", base_frame="odom"))
        self.assertIsNone(conv.base_to_camera(kept, "base_link"))
        self.assertIsNotNone(conv.base_to_camera(rvwo_bag.mounts(published[:2]), "base_link"))  # once: a mount


if __name__ == "__main__":
    unittest.main()
