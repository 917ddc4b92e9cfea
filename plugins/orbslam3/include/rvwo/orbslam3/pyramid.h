// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
//
// ORB-SLAM3's image pyramid with each level where its keypoints' coordinates say it is.
//
// ORBextractor finds a keypoint at pixel (i, j) of level n and puts it at (i, j) * s^n of the image
// (s: ORBextractor.scaleFactor, 1.2). Its level n is cv::resize of level n - 1 to
// cvRound(W / s^n) x cvRound(H / s^n), and cv::resize samples pixel i of its output at
// (i + 0.5) * r - 0.5 of its input, r the ratio of the two sizes. Level n's pixel i is then at
// (i + 0.5) * c_n - 0.5 of the image, c_n = W / cvRound(W / s^n), not at i * s^n:
//   - 0.5 * (c_n - 1) px up and to the left of it, the same in both images of a stereo pair, growing
//     with the level (0.1 px at level 1, 1.3 px at level 7): a point seen at coarser levels as the
//     camera nears it drifts up and to the left across the image;
//   - and i * (s^n - c_n) px: the rounded sizes make c_n differ from s^n by up to 0.2 % (640 px
//     wide: level 7, c_7 = 640 / 179 = 3.575 against 1.2^7 = 3.583), so that a disparity measured
//     at level 7 is 0.22 % too large, at level 6 0.16 % too small.
// On the simulator's stereo suite ORB-SLAM3's keyframes' stereo depths were unbiased (median
// ratio to the true depth 0.9998) but its map points, once bundle adjusted, 0.15 % short at every
// depth and time (0.9985; 0.9983 with the wheels), and so was its trajectory (sim3 scale 1.0015):
// the wheels' distance scale, learnt from that map, followed it (patches/orbslam3/README.md).
//
// resamplePyramidLevel samples the level at the coordinates ORB-SLAM3 gives its keypoints instead:
// pixel (i, j) of `level` is the finer level's (i * step, j * step), bilinear as cv::resize's
// INTER_LINEAR, so the level holds the same content at the phase the coordinates assume. Called
// level by level (step = s), pixel i of level n is the image's i * s^n. The map points' ratio to
// the true depth became 1.0003 with the same resampling done by cv::warpAffine (vision alone, one
// run), whose positions are rounded to 1/32 px; this exact version was measured with the wheels.
//
// C++11: ORB-SLAM3's ORBextractor.cc includes it.
#pragma once

namespace cv {
class Mat;
}

namespace rvwo {
namespace orbslam3 {

// `finer`: 8-bit or float, one channel. `level`: allocated, of the level's size and `finer`'s type
// (ORB-SLAM3's pyramid keeps each level inside a bordered buffer and writes it in place); its pixel
// (i, j) becomes `finer` bilinearly at (i * step, j * step) (8-bit: rounded to the nearest),
// beyond its last row or column its edge. step > 0: finer's pixels per level pixel. Throws
// std::invalid_argument on an empty image, another type, a `level` not allocated as above, or a
// step that is not finite and > 0.
void resamplePyramidLevel(const cv::Mat& finer, cv::Mat& level, double step);

}  // namespace orbslam3
}  // namespace rvwo
