// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The simulator's world: a room (floor, ceiling, four walls) with furniture boxes, every surface
// textured with corner-rich patterns generated from a seed, and walkers that move along segments:
// real people cut from photographs, or people-sized textured cylinders. Rendered by casting one
// ray per pixel.
#pragma once

#include <Eigen/Geometry>
#include <functional>
#include <opencv2/core.hpp>
#include <random>
#include <vector>

#include "rvwo/edges/camera.h"

namespace rvwo::sim {

struct Walker {
  Eigen::Vector2d a, b;  // walks a -> b -> a ... at speed (m/s), from t_on to t_off (s)
  double speed = 1.0, phase = 0.0, t_on = 0.0, t_off = 1e18;
  double radius = 0.25, height = 1.75;
  // How the walker looks: -1 a textured cylinder; k >= 0 a real person (people.h), drawn upright
  // on the floor facing the camera, person k / 2, mirrored when k is odd, scaled by height / 1.75.
  int look = -1;
  // An escort walks around the robot instead: ahead of it by `ahead` m, sweeping across its view
  // by +-`sweep` m with the given period (s). Its position then comes from escortAt().
  bool escort = false;
  double ahead = 2.5, sweep = 1.5, period = 8.0;
  Eigen::Vector2d at(double t) const;
  Eigen::Vector2d escortAt(double t, const Eigen::Vector2d& robot, double heading) const {
    const double lateral = sweep * std::sin(2 * M_PI * t / period + phase);
    const double forward = ahead + 0.5 * std::sin(2 * M_PI * t / (1.7 * period) + 2 * phase);
    return robot + forward * Eigen::Vector2d(std::cos(heading), std::sin(heading)) +
           lateral * Eigen::Vector2d(-std::sin(heading), std::cos(heading));
  }
  bool present(double t) const { return t >= t_on && t < t_off; }
};

// A textured planar patch: origin, two unit axes spanning it, extent along each, texels/metre.
struct Surface {
  Eigen::Vector3d origin, u, v, normal;
  double width, height;
  double texels_per_m;
  int texture;  // index into Scene::textures
};

// What a ray sees: the light reaching each pixel; the camera (camera_effects.h) makes the image.
struct Render {
  cv::Mat radiance;   // CV_64F, grey levels at unit exposure: texture, contrast, illumination, blackout
  cv::Mat depth;      // CV_32F, z in the camera frame (m); 0 where nothing is hit
  cv::Mat labels;     // CV_8U: 0 background, walker_label where a walker is seen
  cv::Mat walker;     // CV_8S: index into the walkers present (Scene::walkerAt), -1 elsewhere
  cv::Mat albedo;     // CV_32F, the surface's own shade (0-255), before light and contrast
  cv::Mat incidence;  // CV_32F, cosine of the angle between the ray and the surface's normal
};

struct RenderOptions {
  double gain = 1.0;      // illumination: multiplies the radiance
  double contrast = 1.0;  // low texture: 1 full, 0 flat grey
  bool blackout = false;  // lens covered: a dark image
  int walker_label = 15;  // class id of walkers in the label image (VOC-21 person)
};

// Where a camera is over a frame's exposure: its pose and the robot's planar pose (x, y, heading;
// escorts walk around it) as functions of time. Row y is read at rowTime(y): the frame's time at
// the middle row, row_delay seconds a row apart (a rolling shutter; 0 for a global one).
struct View {
  std::function<Eigen::Isometry3d(double)> T_w_c;
  std::function<Eigen::Vector3d(double)> robot;
  double t = 0;
  double row_delay = 0;
  double rowTime(int y, int rows) const { return t + (y - 0.5 * (rows - 1)) * row_delay; }
};

class Scene {
 public:
  // A room of size_x by size_y metres (centred on the origin), height h, with furniture and
  // textures from the seed.
  Scene(double size_x, double size_y, double h, unsigned seed, int furniture = 6);
  void addWalker(const Walker& w);
  const std::vector<Walker>& walkers() const { return walkers_; }
  const std::vector<Surface>& surfaces() const { return surfaces_; }
  // Static 3-D points at texture corners (rectangle corners of at least 8 cm), for tests and
  // for seeding maps in experiments.
  const std::vector<Eigen::Vector3d>& landmarks() const { return landmarks_; }
  const std::vector<Eigen::Vector3d>& landmarkNormals() const { return landmark_normals_; }  // facing the room
  double sizeX() const { return sx_; }
  double sizeY() const { return sy_; }

  // Rays in the camera frame for every pixel of a camera (unit vectors), computed once.
  static cv::Mat rayTable(const CameraModel& camera, int width, int height);
  // Renders what a camera sees over a view (each row at its time); rays from rayTable.
  Render render(const View& view, const cv::Mat& rays, const RenderOptions& o) const;
  // The same from a camera standing at T_w_c at time t, the robot at robot.
  Render render(const Eigen::Isometry3d& T_w_c, const cv::Mat& rays, double t, const RenderOptions& o,
                const Eigen::Vector3d& robot = Eigen::Vector3d::Zero()) const;
  // Where walker i is at t (on the floor), the robot then at robot (escorts walk around it).
  Eigen::Vector2d walkerAt(std::size_t i, double t, const Eigen::Vector3d& robot) const;
  // Motion blur: each pixel's radiance averaged along the path its point (the room's, or a
  // walker's as it walks) takes across the image while the shutter is open, exposure seconds
  // around the row's time; camera: the one rays came from.
  cv::Mat motionBlur(const Render& r, const View& view, const cv::Mat& rays, const CameraModel& camera,
                     double exposure) const;

 private:
  // The nearest wall, floor, ceiling or furniture face a ray from o along d meets before *best:
  // *best and *surface updated.
  void hitStatic(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double* best, int* surface) const;
  void addBox(double cx, double cy, double w, double d, double h, std::mt19937_64& rng);
  int makeTexture(int w, int h, std::mt19937_64& rng, bool clothes);
  void addSurface(const Eigen::Vector3d& o, const Eigen::Vector3d& u, const Eigen::Vector3d& v, double w, double h,
                  double tpm, std::mt19937_64& rng);
  struct Box {
    double lo[3], hi[3];
    int face[6];  // surface of the -x, +x, -y, +y, -z (unused), +z faces
  };
  double sx_, sy_, h_;
  unsigned seed_;
  int room_face_[6];  // surfaces of the walls at -x, +x, -y, +y, the floor and the ceiling
  std::vector<Box> boxes_;
  std::vector<Surface> surfaces_;
  std::vector<cv::Mat> textures_;
  std::vector<std::vector<cv::Rect>> rects_;  // per texture: rectangles drawn (texels)
  std::vector<Walker> walkers_;
  std::vector<int> walker_texture_;
  std::vector<Eigen::Vector3d> landmarks_, landmark_normals_;
};

}  // namespace rvwo::sim
