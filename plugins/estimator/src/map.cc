// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "map.h"

#include <algorithm>
#include <cmath>

#include "epipolar_index.h"
#include "rvwo/kernels/barron.h"
#include "rvwo/tracking/planar_pose.h"

namespace rvwo::estimator {

Map::Map(const Context& ctx, bool labels_later)
    : reliability(ctx.opt.reliability), ctx_(ctx), labels_later_(labels_later) {}

SE2 Map::kfPose(std::uint64_t id) const {
  auto it = keyframes.find(id);
  if (it != keyframes.end()) return SE2::fromVector(it->second.x);
  auto f = final_pose.find(id);
  return f != final_pose.end() ? f->second : SE2();
}

double Map::kernelAlpha(std::uint64_t point) const {
  switch (ctx_.opt.kernel) {
    case KernelChoice::kHuber:
      return 1.0;  // unused
    case KernelChoice::kFixed:
      return ctx_.opt.fixed_alpha;
    case KernelChoice::kAdaptive:
      return reliability.alpha(point);
  }
  return 1.0;
}

bool Map::isTrusted(std::uint64_t point) const {
  if (labels_later_) {
    auto p = points.find(point);
    if (p != points.end()) {
      auto kf = keyframes.find(p->second.first_kf);
      if (kf != keyframes.end() && !kf->second.segmented) return false;
    }
  }
  const std::optional<LandmarkReliability> r = reliability.get(point);
  return !r || r->ps < ctx_.opt.tracking.trusted_max_ps;
}

std::vector<char> Map::trustedOf(const std::vector<Match>& matches) const {
  std::vector<char> trusted(matches.size());
  for (std::size_t k = 0; k < matches.size(); ++k) trusted[k] = isTrusted(matches[k].point);
  return trusted;
}

int Map::createKeyFrame(double t, const Eigen::Vector3d& x, Features&& f, std::vector<std::int64_t> point_of,
                        const cv::Mat& image, int tracked, const std::vector<char>& no_new_point) {
  KeyFrame kf;
  kf.id = next_kf++;
  kf.t = t;
  kf.x = x;
  kf.f = std::move(f);
  kf.tracked = tracked;
  kf.point = point_of.empty() ? std::vector<std::int64_t>(kf.f.size(), -1) : std::move(point_of);
  kf.image = image;  // for the segmenter: the camera's raw image
  for (std::size_t i = 0; i < kf.f.size(); ++i) {
    if (kf.point[i] >= 0) points.at(kf.point[i]).obs[kf.id] = static_cast<int>(i);
  }
  // New points: untracked features with depth (none on walkers: no_new_point), nearest first;
  // every close one, at least 100. The first keyframe maps every feature with depth, as ORB-SLAM3's
  // stereo and RGB-D initialisation does: a close walker then holds no sway over the next frames
  // (docs/decisions/0016).
  std::vector<int> cand;
  for (std::size_t i = 0; i < kf.f.size(); ++i) {
    if (kf.point[i] < 0 && kf.f.depth[i] > 0 && (no_new_point.empty() || !no_new_point[i]))
      cand.push_back(static_cast<int>(i));
  }
  std::sort(cand.begin(), cand.end(), [&](int a, int b) { return kf.f.depth[a] < kf.f.depth[b]; });
  const double close = ctx_.opt.max_depth_baselines * ctx_.rig.baseline;
  const SE2 T_w_b = SE2::fromVector(x);
  const bool first = keyframes.empty();
  int made = 0;
  for (int i : cand) {
    if (!first && kf.f.depth[i] > close && made >= 100) break;
    const cv::KeyPoint& kp = kf.f.keypoints[i];
    const Eigen::Vector3d P_c = kf.f.depth[i] * ctx_.rig.camera->unproject(Eigen::Vector2d(kp.pt.x, kp.pt.y));
    const Eigen::Vector3d P_b = ctx_.rig.T_b_c * P_c;
    const Eigen::Vector2d xy = T_w_b.act(P_b.head<2>());
    newPoint(&kf, i, Eigen::Vector3d(xy.x(), xy.y(), P_b.z()), P_c.norm());
    ++made;
  }
  const std::uint64_t id = kf.id;
  keyframes.emplace(id, std::move(kf));
  KeyFrame& added = keyframes.at(id);
  // RGB-D triangulates no walker's feature either (decision 0020); mono is not measured with that.
  if (ctx_.rig.sensor == Sensor::kMono) made += triangulate(&added, {});
  if (ctx_.rig.sensor == Sensor::kRgbd) made += triangulate(&added, no_new_point);
  counters.map_points_created += made;
  if (added.tracked == 0) added.tracked = made;
  return made;
}

MapPoint& Map::newPoint(KeyFrame* kf, int i, const Eigen::Vector3d& P_w, double distance) {
  MapPoint p;
  p.id = next_point++;
  p.P = P_w;
  p.descriptor = kf->f.descriptors.row(i).clone();
  p.level = kf->f.keypoints[i].octave;
  p.distance = distance;
  p.obs[kf->id] = i;
  p.visible = p.found = 1;
  p.first_kf = kf->id;
  kf->point[i] = static_cast<std::int64_t>(p.id);
  return points.emplace(p.id, std::move(p)).first->second;
}

int Map::triangulate(KeyFrame* kf, const std::vector<char>& no_new_point) {
  const Eigen::Isometry3d T_w_c1 = ctx_.T_w_c(kf->x);
  const double cos_min = std::cos(ctx_.opt.mono_min_parallax * M_PI / 180.0);
  std::vector<double> tolerance(ctx_.opt.levels);  // rad off the epipolar plane, by pyramid level
  for (int l = 0; l < ctx_.opt.levels; ++l)
    tolerance[l] = 3.0 * ctx_.opt.sigma_px * std::pow(ctx_.opt.scale_factor, l) / ctx_.rig.camera->fx() + 2e-3;
  auto rays = [&](const KeyFrame& k, const Eigen::Isometry3d& T_w_c) {
    std::vector<Eigen::Vector3d> d(k.f.size());
    for (std::size_t i = 0; i < k.f.size(); ++i) {
      const cv::Point2f& pt = k.f.keypoints[i].pt;
      d[i] = (T_w_c.linear() * ctx_.rig.camera->unproject(Eigen::Vector2d(pt.x, pt.y))).normalized();
    }
    return d;
  };
  const std::vector<Eigen::Vector3d> d1 = rays(*kf, T_w_c1);
  int made = 0;
  auto it = keyframes.find(kf->id);
  for (int n = 0; n < kTriangulationNeighbours && it != keyframes.begin(); ++n) {
    KeyFrame& old = (--it)->second;
    const Eigen::Isometry3d T_w_c2 = ctx_.T_w_c(old.x);
    const Eigen::Vector3d c1 = T_w_c1.translation(), c2 = T_w_c2.translation(), base = c2 - c1;
    if (base.norm() < ctx_.opt.mono_min_baseline) continue;
    const std::vector<Eigen::Vector3d> d2 = rays(old, T_w_c2);
    std::vector<int> free_old;
    for (std::size_t j = 0; j < old.f.size(); ++j) {
      if (old.point[j] < 0) free_old.push_back(static_cast<int>(j));
    }
    const EpipolarIndex index(base, d2, free_old);
    std::vector<int> near;
    std::vector<int> best_dist(old.f.size(), 51), best_of(old.f.size(), -1);
    for (std::size_t i = 0; i < kf->f.size(); ++i) {
      if (kf->point[i] >= 0 || (!no_new_point.empty() && no_new_point[i])) continue;
      const Eigen::Vector3d normal = d1[i].cross(base).normalized();  // of the epipolar plane
      const int level = kf->f.keypoints[i].octave;
      index.near(d1[i], tolerance[std::min(level + 1, ctx_.opt.levels - 1)], &near);
      const unsigned char* descriptor = kf->f.descriptors.ptr<unsigned char>(static_cast<int>(i));
      BestTwo match;
      for (int j : near) {
        const int old_level = old.f.keypoints[j].octave;
        if (std::abs(old_level - level) > 1) continue;
        if (std::fabs(normal.dot(d2[j])) > tolerance[std::max(level, old_level)] || d1[i].dot(d2[j]) > cos_min)
          continue;
        match.offerAnyOrder(hammingDistance(descriptor, old.f.descriptors.ptr<unsigned char>(j)), j);
      }
      if (match.index < 0 || match.best > 50 || match.best > 0.8 * match.second) continue;
      if (match.best < best_dist[match.index]) {
        best_dist[match.index] = match.best;
        best_of[match.index] = static_cast<int>(i);
      }
    }
    for (std::size_t j = 0; j < old.f.size(); ++j) {
      const int i = best_of[j];
      if (i < 0 || kf->point[i] >= 0) continue;
      // Midpoint of the closest approach of c1 + a d1 and c2 + b d2.
      const Eigen::Vector3d &u = d1[i], &v = d2[j];
      const double uv = u.dot(v), den = 1.0 - uv * uv;
      if (den < 1e-9) continue;
      const double a = (u.dot(base) - uv * v.dot(base)) / den, b = (uv * u.dot(base) - v.dot(base)) / den;
      if (a <= 0 || b <= 0) continue;
      const Eigen::Vector3d P = 0.5 * (c1 + a * u + c2 + b * v);
      auto fits = [&](const KeyFrame& k, int f) {
        double e2;
        const double sigma = ctx_.sigmaAt(k.f.keypoints[f].octave);
        return ctx_.chi2(false, k.x, P, Context::observation(k.f, f), sigma, &e2) && e2 <= kChi2Mono;
      };
      if (!fits(*kf, i) || !fits(old, static_cast<int>(j))) continue;
      MapPoint& p = newPoint(kf, i, P, (P - c1).norm());
      p.obs[old.id] = static_cast<int>(j);
      old.point[j] = static_cast<std::int64_t>(p.id);
      ++made;
    }
  }
  return made;
}

void Map::cullPoints() {
  std::lock_guard<std::mutex> lock(mutex);
  if (keyframes.empty()) return;
  const std::uint64_t newest = std::prev(keyframes.end())->first;
  for (auto it = points.begin(); it != points.end();) {
    const MapPoint& p = it->second;
    const bool rarely_found = p.visible >= 8 && p.found < 0.25 * p.visible;
    const bool lonely = newest >= p.first_kf + 3 && p.obs.size() <= 1 && ctx_.rig.sensor == Sensor::kMono;
    if (rarely_found || lonely || p.obs.empty()) {
      eraseObservations(p);
      forget(it->first);
      it = points.erase(it);
    } else {
      ++it;
    }
  }
}

void Map::eraseObservations(const MapPoint& p) {
  for (const auto& [kf_id, feature] : p.obs) {
    auto kf = keyframes.find(kf_id);
    if (kf != keyframes.end()) kf->second.point[feature] = -1;
  }
}

std::optional<double> Map::dropOldKeyFrames() {
  std::lock_guard<std::mutex> lock(mutex);
  while (keyframes.size() > static_cast<std::size_t>(ctx_.opt.keep_keyframes)) {
    auto it = keyframes.begin();
    const KeyFrame& kf = it->second;
    final_pose[kf.id] = SE2::fromVector(kf.x);
    for (std::size_t i = 0; i < kf.f.size(); ++i) {
      if (kf.point[i] < 0) continue;
      auto p = points.find(kf.point[i]);
      if (p == points.end()) continue;
      p->second.obs.erase(kf.id);
      if (p->second.obs.empty()) {
        forget(p->first);
        points.erase(p);
      }
    }
    keyframes.erase(it);
  }
  if (keyframes.empty()) return std::nullopt;
  return keyframes.begin()->second.t;
}

void Map::forget(std::uint64_t point) {
  if (reliability.alpha(point) == -BarronKernel::kInfinity) ++counters.map_points_rejected;
  reliability.forget(point);
}

}  // namespace rvwo::estimator
