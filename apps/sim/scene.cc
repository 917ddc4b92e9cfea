// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "scene.h"

#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "people.h"

namespace rvwo::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Bilinear lookup of a one-channel image at pixel coordinates (x, y), pixel centres on integers,
// clamped to the image.
template <typename T>
inline double bilinear(const cv::Mat& m, double x, double y) {
  x = std::min(std::max(x, 0.0), m.cols - 1.001);
  y = std::min(std::max(y, 0.0), m.rows - 1.001);
  const int ix = static_cast<int>(x), iy = static_cast<int>(y);
  const double fx = x - ix, fy = y - iy;
  const T* r0 = m.ptr<T>(iy);
  const T* r1 = m.ptr<T>(iy + 1);
  return (1 - fy) * ((1 - fx) * r0[ix] + fx * r0[ix + 1]) + fy * ((1 - fx) * r1[ix] + fx * r1[ix + 1]);
}

// A texture at texel coordinates (x, y): texel centres at half-integers.
inline double sample(const cv::Mat& tex, double x, double y) { return bilinear<uint8_t>(tex, x - 0.5, y - 0.5); }

}  // namespace

Eigen::Vector2d Walker::at(double t) const {
  const double len = (b - a).norm();
  if (len <= 0) return a;
  double s = std::fmod(speed * t + phase, 2 * len);
  if (s < 0) s += 2 * len;
  return a + (b - a) * ((s < len ? s : 2 * len - s) / len);
}

int Scene::makeTexture(int w, int h, std::mt19937_64& rng, bool clothes) {
  std::uniform_int_distribution<int> grey(40, 215), size(clothes ? 6 : 8, clothes ? 18 : 40);
  cv::Mat tex(h, w, CV_8U, cv::Scalar(grey(rng)));
  std::vector<cv::Rect> rects;
  cv::Mat taken(h, w, CV_8U, cv::Scalar(0));
  const int tries = w * h / 150;
  for (int i = 0; i < tries; ++i) {
    const int rw = size(rng), rh = size(rng);
    if (rw + 16 >= w || rh + 16 >= h) continue;  // 8 texels from the surface's borders, like between rectangles
    const int ry = std::uniform_int_distribution<int>(8, h - rh - 8)(rng);  // y first, on every compiler
    const int rx = std::uniform_int_distribution<int>(8, w - rw - 8)(rng);
    const cv::Rect r(rx, ry, rw, rh);
    // 8 texels (8 cm) of background around every rectangle: corners stay visible and apart, so a
    // detector (and the geometry test) sees one corner at a time.
    const cv::Rect gap(r.x - 8, r.y - 8, r.width + 16, r.height + 16);
    if (cv::countNonZero(taken(gap & cv::Rect(0, 0, w, h))) > 0) continue;
    int g = grey(rng);
    const int back = tex.at<uint8_t>(0, 0);
    if (std::abs(g - back) < 50) g = back > 127 ? back - 90 : back + 90;  // contrast for corners
    tex(r).setTo(g);
    taken(r).setTo(1);
    rects.push_back(r);
  }
  textures_.push_back(tex);
  rects_.push_back(rects);
  return static_cast<int>(textures_.size()) - 1;
}

void Scene::addSurface(const Eigen::Vector3d& o, const Eigen::Vector3d& u, const Eigen::Vector3d& v, double w, double h,
                       double tpm, std::mt19937_64& rng) {
  const int tex =
      makeTexture(std::max(8, static_cast<int>(w * tpm)), std::max(8, static_cast<int>(h * tpm)), rng, false);
  surfaces_.push_back({o, u, v, u.cross(v), w, h, tpm, tex});
  for (const cv::Rect& r : rects_[tex]) {
    for (const cv::Point& c : {r.tl(), cv::Point(r.x + r.width, r.y), r.br(), cv::Point(r.x, r.y + r.height)}) {
      landmarks_.push_back(o + u * (c.x / tpm) + v * (c.y / tpm));
      landmark_normals_.push_back(u.cross(v));
    }
  }
}

void Scene::addBox(double cx, double cy, double w, double d, double h, std::mt19937_64& rng) {
  Box b{{cx - w / 2, cy - d / 2, 0}, {cx + w / 2, cy + d / 2, h}, {}};
  const Eigen::Vector3d X = Eigen::Vector3d::UnitX(), Y = Eigen::Vector3d::UnitY(), Z = Eigen::Vector3d::UnitZ();
  const double tpm = 100;
  b.face[0] = static_cast<int>(surfaces_.size());
  addSurface({b.lo[0], b.hi[1], h}, -Y, -Z, d, h, tpm, rng);
  b.face[1] = static_cast<int>(surfaces_.size());
  addSurface({b.hi[0], b.lo[1], h}, Y, -Z, d, h, tpm, rng);
  b.face[2] = static_cast<int>(surfaces_.size());
  addSurface({b.lo[0], b.lo[1], h}, X, -Z, w, h, tpm, rng);
  b.face[3] = static_cast<int>(surfaces_.size());
  addSurface({b.hi[0], b.hi[1], h}, -X, -Z, w, h, tpm, rng);
  b.face[4] = -1;
  b.face[5] = static_cast<int>(surfaces_.size());
  addSurface({b.lo[0], b.lo[1], h}, X, Y, w, d, tpm, rng);
  boxes_.push_back(b);
}

Scene::Scene(double size_x, double size_y, double h, unsigned seed, int furniture)
    : sx_(size_x), sy_(size_y), h_(h), seed_(seed) {
  std::mt19937_64 rng(seed);
  const double x0 = -sx_ / 2, x1 = sx_ / 2, y0 = -sy_ / 2, y1 = sy_ / 2;
  const Eigen::Vector3d X = Eigen::Vector3d::UnitX(), Y = Eigen::Vector3d::UnitY(), Z = Eigen::Vector3d::UnitZ();
  const double tpm = 100;  // texels per metre: 1 cm texels
  room_face_[0] = static_cast<int>(surfaces_.size());
  addSurface({x0, y1, h}, -Y, -Z, sy_, h, tpm, rng);  // wall at -x, seen from inside
  room_face_[1] = static_cast<int>(surfaces_.size());
  addSurface({x1, y0, h}, Y, -Z, sy_, h, tpm, rng);
  room_face_[2] = static_cast<int>(surfaces_.size());
  addSurface({x0, y0, h}, X, -Z, sx_, h, tpm, rng);
  room_face_[3] = static_cast<int>(surfaces_.size());
  addSurface({x1, y1, h}, -X, -Z, sx_, h, tpm, rng);
  room_face_[4] = static_cast<int>(surfaces_.size());
  addSurface({x0, y0, 0}, X, Y, sx_, sy_, 50, rng);  // floor: 2 cm texels
  room_face_[5] = static_cast<int>(surfaces_.size());
  addSurface({x0, y1, h}, X, -Y, sx_, sy_, 25, rng);  // ceiling: 4 cm texels
  // Furniture along the walls, within 0.9 m of them, leaving the middle free for the robot.
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < furniture; ++i) {
    const double w = 0.4 + 0.8 * u(rng), d = 0.3 + 0.3 * u(rng), bh = 0.4 + 1.2 * u(rng);
    const int wall = i % 4;
    const double s = u(rng);
    if (wall == 0) addBox(x0 + d / 2 + 0.05, y0 + 1 + s * (sy_ - 2), d, w, bh, rng);
    if (wall == 1) addBox(x1 - d / 2 - 0.05, y0 + 1 + s * (sy_ - 2), d, w, bh, rng);
    if (wall == 2) addBox(x0 + 1 + s * (sx_ - 2), y0 + d / 2 + 0.05, w, d, bh, rng);
    if (wall == 3) addBox(x0 + 1 + s * (sx_ - 2), y1 - d / 2 - 0.05, w, d, bh, rng);
  }
}

void Scene::addWalker(const Walker& w) {
  std::mt19937_64 rng(seed_ * 7919u + walkers_.size() + 1);
  walkers_.push_back(w);
  // Clothes: around the cylinder (2 pi r) by its height, 1 cm texels.
  walker_texture_.push_back(
      makeTexture(static_cast<int>(2 * M_PI * w.radius * 100), static_cast<int>(w.height * 100), rng, true));
}

cv::Mat Scene::rayTable(const CameraModel& camera, int width, int height) {
  cv::Mat rays(height, width, CV_32FC3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const Eigen::Vector3d r = camera.unproject(Eigen::Vector2d(x, y)).normalized();
      rays.at<cv::Vec3f>(y, x) =
          cv::Vec3f(static_cast<float>(r.x()), static_cast<float>(r.y()), static_cast<float>(r.z()));
    }
  }
  return rays;
}

Eigen::Vector2d Scene::walkerAt(std::size_t i, double t, const Eigen::Vector3d& robot) const {
  const Walker& w = walkers_[i];
  return w.escort ? w.escortAt(t, robot.head<2>(), robot.z()) : w.at(t);
}

Render Scene::render(const Eigen::Isometry3d& T_w_c, const cv::Mat& rays, double t, const RenderOptions& o,
                     const Eigen::Vector3d& robot) const {
  View view;
  view.T_w_c = [&T_w_c](double) { return T_w_c; };
  view.robot = [&robot](double) { return robot; };
  view.t = t;
  return render(view, rays, o);
}

namespace {

// Where a ray meets a person: its distance (0: no person), their shade and the incidence.
struct PersonHit {
  double t = 0, value = 0, cosine = 1;
};

// A person as the rays from o see them: the person `look` standing at base, `height` / 1.75 times
// their photographed size, upright and facing o. Made once a row of rays.
struct Picture {
  const Person* person = nullptr;                   // null: o stands where they do
  Eigen::Vector3d base = Eigen::Vector3d::Zero();   // where they stand
  Eigen::Vector3d n = Eigen::Vector3d::Zero();      // the picture's normal, towards o
  Eigen::Vector3d right = Eigen::Vector3d::Zero();  // the viewer's right
  double offset = 0;                                // (base - o) . n
  double tall = 0, wide = 0;                        // m
  bool mirrored = false;
};

Picture pictureOf(double x, double y, double height, int look, const Eigen::Vector3d& o) {
  Picture pic;
  const Person& p = people()[look / 2];
  const Eigen::Vector2d towards(o.x() - x, o.y() - y);
  const double dist = towards.norm();
  if (dist < 1e-6) return pic;
  pic.person = &p;
  pic.base = Eigen::Vector3d(x, y, 0);
  pic.n = Eigen::Vector3d(towards.x() / dist, towards.y() / dist, 0);
  pic.right = Eigen::Vector3d(-pic.n.y(), pic.n.x(), 0);  // looking along -n
  pic.offset = (pic.base - o).dot(pic.n);
  pic.tall = p.metres * height / 1.75;
  pic.wide = pic.tall * p.grey.cols / p.grey.rows;
  pic.mirrored = look % 2;
  return pic;
}

// A ray from o along d against a picture: a hit nearer than `nearest` on an opaque pixel.
bool hitPerson(const Picture& pic, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double nearest, PersonHit* hit) {
  if (!pic.person) return false;
  const Person& p = *pic.person;
  const double dn = d.dot(pic.n);
  if (dn > -1e-9) return false;
  const double t = pic.offset / dn;
  if (t <= 0 || t >= nearest) return false;
  const Eigen::Vector3d q = o + t * d - pic.base;
  double u = (q.dot(pic.right) / pic.wide + 0.5) * p.grey.cols;
  const double v = (1 - q.z() / pic.tall) * p.grey.rows;
  if (u < 0 || u >= p.grey.cols || v < 0 || v >= p.grey.rows) return false;
  if (pic.mirrored) u = p.grey.cols - u;
  const int iu = std::min(static_cast<int>(u), p.grey.cols - 1), iv = std::min(static_cast<int>(v), p.grey.rows - 1);
  if (p.alpha.at<uint8_t>(iv, iu) < 128) return false;
  hit->t = t;
  hit->value = bilinear<uint8_t>(p.grey, u - 0.5, v - 0.5);
  hit->cosine = -dn;
  return true;
}

// What a row of pixels is cast from: the camera then, and the walkers present then.
struct RowScene {
  struct Cyl {
    double x, y, r, h;
    int tex, index, look;
    Picture picture;  // a person's (look >= 0)
  };
  Eigen::Matrix3d R;
  Eigen::Vector3d o;
  std::vector<Cyl> cyls;
};

}  // namespace

void Scene::hitStatic(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double* best_out, int* surface) const {
  double best = *best_out;
  // Room: the ray leaves the box [lo, hi] through one face.
  const double lo[3] = {-sx_ / 2, -sy_ / 2, 0.0}, hi[3] = {sx_ / 2, sy_ / 2, h_};
  // 1/d once per ray: the slab tests below multiply instead of dividing.
  const double inv[3] = {std::fabs(d[0]) > 1e-12 ? 1.0 / d[0] : 0.0, std::fabs(d[1]) > 1e-12 ? 1.0 / d[1] : 0.0,
                         std::fabs(d[2]) > 1e-12 ? 1.0 / d[2] : 0.0};
  for (int a = 0; a < 3; ++a) {
    if (d[a] > 1e-12) {
      const double tt = (hi[a] - o[a]) * inv[a];
      if (tt < best) best = tt, *surface = room_face_[2 * a + 1];
    } else if (d[a] < -1e-12) {
      const double tt = (lo[a] - o[a]) * inv[a];
      if (tt < best) best = tt, *surface = room_face_[2 * a];
    }
  }
  // Furniture: slab entry.
  for (const Box& b : boxes_) {
    double t0 = 0, t1 = best;
    int face = -1;
    bool miss = false;
    for (int a = 0; a < 3 && !miss; ++a) {
      if (std::fabs(d[a]) < 1e-12) {
        miss = o[a] < b.lo[a] || o[a] > b.hi[a];
        continue;
      }
      double ta = (b.lo[a] - o[a]) * inv[a], tb = (b.hi[a] - o[a]) * inv[a];
      int fa = 2 * a, fb = 2 * a + 1;
      if (ta > tb) std::swap(ta, tb), std::swap(fa, fb);
      if (ta > t0) t0 = ta, face = fa;
      t1 = std::min(t1, tb);
      miss = t0 > t1;
    }
    if (!miss && face >= 0 && b.face[face] >= 0 && t0 < best) best = t0, *surface = b.face[face];
  }
  *best_out = best;
}

Render Scene::render(const View& view, const cv::Mat& rays, const RenderOptions& opt) const {
  Render out;
  out.radiance.create(rays.size(), CV_64F);
  out.depth.create(rays.size(), CV_32F);
  out.labels.create(rays.size(), CV_8U);
  out.walker.create(rays.size(), CV_8S);
  out.albedo.create(rays.size(), CV_32F);
  out.incidence.create(rays.size(), CV_32F);
  auto sceneAt = [&](double t) {
    RowScene rs;
    const Eigen::Isometry3d T_w_c = view.T_w_c(t);
    rs.R = T_w_c.linear();
    rs.o = T_w_c.translation();
    const Eigen::Vector3d robot = view.robot(t);
    for (std::size_t i = 0; i < walkers_.size(); ++i) {
      if (!walkers_[i].present(t)) continue;
      const Eigen::Vector2d c = walkerAt(i, t, robot);
      const Walker& w = walkers_[i];
      rs.cyls.push_back({c.x(), c.y(), w.radius, w.height, walker_texture_[i], static_cast<int>(i), w.look, Picture()});
      if (w.look >= 0) rs.cyls.back().picture = pictureOf(c.x(), c.y(), w.height, w.look, rs.o);
    }
    return rs;
  };
  const RowScene global = sceneAt(view.t);  // every row's, under a global shutter
  cv::parallel_for_(cv::Range(0, rays.rows), [&](const cv::Range& range) {
    for (int y = range.start; y < range.end; ++y) {
      const RowScene rolling = view.row_delay != 0 ? sceneAt(view.rowTime(y, rays.rows)) : RowScene();
      const RowScene& rs = view.row_delay != 0 ? rolling : global;
      const Eigen::Matrix3d& R = rs.R;
      const Eigen::Vector3d& o = rs.o;
      const Eigen::Vector3d zc = R.col(2);
      const cv::Vec3f* ray = rays.ptr<cv::Vec3f>(y);
      double* rad = out.radiance.ptr<double>(y);
      float* dep = out.depth.ptr<float>(y);
      uint8_t* lab = out.labels.ptr<uint8_t>(y);
      int8_t* who = out.walker.ptr<int8_t>(y);
      float* alb = out.albedo.ptr<float>(y);
      float* inc = out.incidence.ptr<float>(y);
      for (int x = 0; x < rays.cols; ++x) {
        const Eigen::Vector3d d = R * Eigen::Vector3d(ray[x][0], ray[x][1], ray[x][2]);
        double best = kInf;
        int surface = -1, walker = -1;
        hitStatic(o, d, &best, &surface);
        // Walkers: vertical cylinders, or people standing on the floor facing the camera.
        PersonHit person;
        for (std::size_t i = 0; i < rs.cyls.size(); ++i) {
          const RowScene::Cyl& c = rs.cyls[i];
          if (c.look >= 0) {
            PersonHit hit;
            if (hitPerson(c.picture, o, d, best, &hit)) {
              best = hit.t, walker = static_cast<int>(i), surface = -1, person = hit;
            }
            continue;
          }
          const double px = o.x() - c.x, py = o.y() - c.y;
          const double A = d.x() * d.x() + d.y() * d.y(), B = px * d.x() + py * d.y(),
                       C = px * px + py * py - c.r * c.r;
          const double disc = B * B - A * C;
          if (A < 1e-12 || disc < 0) continue;
          const double tt = (-B - std::sqrt(disc)) / A;
          const double z = o.z() + tt * d.z();
          if (tt > 0 && tt < best && z >= 0 && z <= c.h) {
            best = tt, walker = static_cast<int>(i), surface = -1, person = PersonHit();
          }
        }
        double value = 0, cosine = 1;
        who[x] = -1;
        lab[x] = 0;
        if (walker >= 0 && person.t > 0) {
          value = person.value;
          cosine = person.cosine;
          lab[x] = static_cast<uint8_t>(opt.walker_label);
          who[x] = static_cast<int8_t>(rs.cyls[walker].index);
        } else if (walker >= 0) {
          const RowScene::Cyl& c = rs.cyls[walker];
          const Eigen::Vector3d p = o + best * d;
          const double ang = std::atan2(p.y() - c.y, p.x() - c.x) + M_PI;
          const cv::Mat& tex = textures_[c.tex];
          value = sample(tex, ang * c.r * 100, (c.h - p.z()) * 100);
          lab[x] = static_cast<uint8_t>(opt.walker_label);
          who[x] = static_cast<int8_t>(c.index);
          cosine = std::fabs(d.x() * (p.x() - c.x) + d.y() * (p.y() - c.y)) / c.r;
        } else if (surface >= 0) {
          const Surface& s = surfaces_[surface];
          const Eigen::Vector3d p = o + best * d - s.origin;
          value = sample(textures_[s.texture], p.dot(s.u) * s.texels_per_m, p.dot(s.v) * s.texels_per_m);
          cosine = std::fabs(d.dot(s.normal));
        }
        dep[x] = std::isfinite(best) ? static_cast<float>(best * d.dot(zc)) : 0.0f;
        alb[x] = static_cast<float>(value);
        inc[x] = static_cast<float>(cosine);
        if (opt.blackout) value = 8;
        rad[x] = (128 + opt.contrast * (value - 128)) * opt.gain;
      }
    }
  });
  return out;
}

cv::Mat Scene::motionBlur(const Render& r, const View& view, const cv::Mat& rays, const CameraModel& camera,
                          double exposure) const {
  cv::Mat out = r.radiance.clone();
  if (exposure <= 0) return out;
  const int max_samples = 64;
  // How a row's points move while the shutter is open, exposure seconds around the row's time t:
  // the camera at t seen from its poses at the opening (a) and closing (b), and how far each walker
  // moves in those cameras' frames.
  struct RowMotion {
    Eigen::Isometry3d T_a_c, T_b_c;
    std::vector<Eigen::Vector3d> moved_a, moved_b;
  };
  auto motionAt = [&](double t) {
    const double ta = t - 0.5 * exposure, tb = t + 0.5 * exposure;
    const Eigen::Isometry3d T_w_c = view.T_w_c(t), T_w_a = view.T_w_c(ta), T_w_b = view.T_w_c(tb);
    const Eigen::Vector3d robot = view.robot(t), robot_a = view.robot(ta), robot_b = view.robot(tb);
    RowMotion m{T_w_a.inverse() * T_w_c, T_w_b.inverse() * T_w_c, {}, {}};
    for (std::size_t i = 0; i < walkers_.size(); ++i) {
      const Eigen::Vector2d w = walkerAt(i, t, robot);
      const Eigen::Vector2d da = walkerAt(i, ta, robot_a) - w, db = walkerAt(i, tb, robot_b) - w;
      m.moved_a.push_back(T_w_a.linear().transpose() * Eigen::Vector3d(da.x(), da.y(), 0));
      m.moved_b.push_back(T_w_b.linear().transpose() * Eigen::Vector3d(db.x(), db.y(), 0));
    }
    return m;
  };
  const RowMotion global = motionAt(view.t);  // every row's, under a global shutter
  cv::parallel_for_(cv::Range(0, rays.rows), [&](const cv::Range& range) {
    for (int y = range.start; y < range.end; ++y) {
      const RowMotion rolling = view.row_delay != 0 ? motionAt(view.rowTime(y, rays.rows)) : RowMotion();
      const RowMotion& m = view.row_delay != 0 ? rolling : global;
      const cv::Vec3f* ray = rays.ptr<cv::Vec3f>(y);
      const float* dep = r.depth.ptr<float>(y);
      const int8_t* who = r.walker.ptr<int8_t>(y);
      double* dst = out.ptr<double>(y);
      for (int x = 0; x < rays.cols; ++x) {
        if (dep[x] <= 0 || ray[x][2] < 0.05f) continue;
        const Eigen::Vector3d P_c = Eigen::Vector3d(ray[x][0], ray[x][1], ray[x][2]) * (dep[x] / ray[x][2]);
        Eigen::Vector3d P_a = m.T_a_c * P_c, P_b = m.T_b_c * P_c;
        if (who[x] >= 0) {  // the walker's point moves with it
          P_a += m.moved_a[who[x]];
          P_b += m.moved_b[who[x]];
        }
        if (P_a.z() <= 0.05 || P_b.z() <= 0.05) continue;
        const Eigen::Vector2d a = camera.project(P_a), b = camera.project(P_b);
        // A sample a pixel along the path's longer axis; a path under half a pixel leaves the pixel
        // as it is.
        const Eigen::Vector2d ab = b - a;
        const int n = std::min(max_samples, 1 + static_cast<int>(std::max(std::fabs(ab.x()), std::fabs(ab.y())) + 0.5));
        if (n <= 1) continue;
        const Eigen::Vector2d step = ab / n;
        Eigen::Vector2d p = a + 0.5 * step;
        double sum = 0;
        for (int i = 0; i < n; ++i, p += step) sum += bilinear<double>(r.radiance, p.x(), p.y());
        dst[x] = sum / n;
      }
    }
  });
  return out;
}

}  // namespace rvwo::sim
