// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "trajectory.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "support/output.h"

namespace rvwo::apps {

Trajectory readTum(const std::string& path, int block, bool lenient) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot be read");
  Trajectory out;
  std::string line;
  int current = 0;  // blocks seen so far
  for (int n = 1; std::getline(in, line); ++n) {
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    if (line.compare(first, 4, "seq:") == 0) {
      if (block > 0 && current == block) break;
      ++current;
      continue;
    }
    const auto token_end = line.find_first_of(" \t", first);
    if (line[std::min(token_end, line.size()) - 1] == ':') continue;  // "scene: home" and such (OpenLORIS)
    if (block > 0 && std::max(current, 1) != block) continue;         // poses before any "seq:" are block 1
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream s(line);
    double v[8];
    std::string token;
    for (double& x : v) {
      char* end = nullptr;
      if (!(s >> token) || (x = std::strtod(token.c_str(), &end), *end != '\0')) {  // strtod: "nan" is a number
        throw std::runtime_error(path + ":" + std::to_string(n) + ": expected 8 numbers 't x y z qx qy qz qw'");
      }
    }
    if (s >> token) throw std::runtime_error(path + ":" + std::to_string(n) + ": more than 8 values");
    for (double x : v) {
      if (!std::isfinite(x)) throw std::runtime_error(path + ":" + std::to_string(n) + ": a value is not finite");
    }
    const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    if (std::fabs(q.norm() - 1.0) > 1e-3) {
      throw std::runtime_error(path + ":" + std::to_string(n) + ": quaternion of norm " + std::to_string(q.norm()));
    }
    if (!out.empty() && !(v[0] > out.back().t)) {
      if (lenient) continue;
      throw std::runtime_error(path + ":" + std::to_string(n) + ": timestamps must increase");
    }
    StampedPose p;
    p.t = v[0];
    p.T.linear() = q.normalized().toRotationMatrix();
    p.T.translation() << v[1], v[2], v[3];
    out.push_back(p);
  }
  if (out.empty()) {
    throw std::runtime_error(path +
                             (block > 0 ? ": no poses in block " + std::to_string(block) : std::string(": no poses")));
  }
  return out;
}

void writeTum(const std::string& path, const Trajectory& trajectory) {
  writeWhole(path, [&](const std::string& tmp) {
    std::ofstream out(tmp);
    if (!out) throw std::runtime_error(path + ": cannot be written");
    out << "# t x y z qx qy qz qw\n" << std::setprecision(17);
    for (const StampedPose& p : trajectory) {
      const Eigen::Quaterniond q(p.T.linear());
      const Eigen::Vector3d& x = p.T.translation();
      out << p.t << ' ' << x.x() << ' ' << x.y() << ' ' << x.z() << ' ' << q.x() << ' ' << q.y() << ' ' << q.z() << ' '
          << q.w() << '\n';
    }
    out.close();
    if (!out) throw std::runtime_error(path + ": write failed");
  });
}

std::vector<std::pair<std::size_t, std::size_t>> associate(const Trajectory& ref, const Trajectory& est,
                                                           double max_dt) {
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  std::size_t j = 0;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    while (j + 1 < est.size() && est[j + 1].t <= ref[i].t) ++j;
    std::size_t best = j;
    if (j + 1 < est.size() && std::fabs(est[j + 1].t - ref[i].t) < std::fabs(est[j].t - ref[i].t)) best = j + 1;
    if (std::fabs(est[best].t - ref[i].t) <= max_dt && (pairs.empty() || pairs.back().second != best)) {
      pairs.emplace_back(i, best);
    }
  }
  return pairs;
}

Alignment parseAlignment(const std::string& name) {
  if (name == "se3") return Alignment::kSE3;
  if (name == "sim3") return Alignment::kSim3;
  if (name == "posyaw") return Alignment::kPosYaw;
  if (name == "none") return Alignment::kNone;
  throw std::invalid_argument("--align: se3, posyaw, sim3 or none, got '" + name + "'");
}

Similarity align(const std::vector<Eigen::Vector3d>& ref, const std::vector<Eigen::Vector3d>& est, Alignment mode) {
  Similarity out;
  if (mode == Alignment::kNone || ref.empty()) return out;
  const double n = static_cast<double>(ref.size());
  Eigen::Vector3d mr = Eigen::Vector3d::Zero(), me = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < ref.size(); ++i) {
    mr += ref[i] / n;
    me += est[i] / n;
  }
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();  // (1/n) sum (ref - mr)(est - me)^T
  double var_e = 0;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    C += (ref[i] - mr) * (est[i] - me).transpose() / n;
    var_e += (est[i] - me).squaredNorm() / n;
  }
  if (mode == Alignment::kPosYaw) {
    // Rotation about z only: maximise sum (ref_xy . R est_xy).
    const double yaw = std::atan2(C(1, 0) - C(0, 1), C(0, 0) + C(1, 1));
    out.R = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  } else {
    // Umeyama (1991): C = U D V^T, R = U S V^T with S fixing a reflection, s = tr(D S) / var_e.
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(C, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
    if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) S(2, 2) = -1;
    out.R = svd.matrixU() * S * svd.matrixV().transpose();
    if (mode == Alignment::kSim3 && var_e > 0) out.s = (svd.singularValues().asDiagonal() * S).trace() / var_e;
  }
  out.t = mr - out.s * out.R * me;
  return out;
}

ErrorStats statistics(const std::vector<double>& e) {
  ErrorStats s;
  s.n = e.size();
  if (e.empty()) return s;
  double sum = 0, sq = 0;
  for (double x : e) {
    sum += x;
    sq += x * x;
  }
  s.mean = sum / e.size();
  s.rmse = std::sqrt(sq / e.size());
  s.std = std::sqrt(std::max(0.0, sq / e.size() - s.mean * s.mean));  // population std, as numpy (and evo)
  std::vector<double> sorted = e;
  std::sort(sorted.begin(), sorted.end());
  const std::size_t m = sorted.size() / 2;
  s.median = sorted.size() % 2 ? sorted[m] : 0.5 * (sorted[m - 1] + sorted[m]);
  s.min = sorted.front();
  s.max = sorted.back();
  return s;
}

AteResult ate(const Trajectory& ref, const Trajectory& est,
              const std::vector<std::pair<std::size_t, std::size_t>>& pairs, Alignment mode) {
  AteResult r;
  std::vector<Eigen::Vector3d> pr, pe;
  for (const auto& [i, j] : pairs) {
    pr.push_back(ref[i].T.translation());
    pe.push_back(est[j].T.translation());
  }
  r.alignment = align(pr, pe, mode);
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const Eigen::Vector3d a = r.alignment.apply(pe[k]);
    r.t.push_back(ref[pairs[k].first].t);
    r.errors.push_back((pr[k] - a).norm());
    r.ref.push_back(pr[k]);
    r.est_aligned.push_back(a);
  }
  r.stats = statistics(r.errors);
  return r;
}

RpeResult rpe(const Trajectory& ref, const Trajectory& est,
              const std::vector<std::pair<std::size_t, std::size_t>>& pairs, double delta, bool delta_in_metres,
              bool pairs_from_reference) {
  if (!(delta > 0)) throw std::invalid_argument("--delta must be > 0");
  RpeResult r;
  auto error = [&](std::size_t a, std::size_t b) {
    const Eigen::Isometry3d dr = ref[pairs[a].first].T.inverse() * ref[pairs[b].first].T;
    const Eigen::Isometry3d de = est[pairs[a].second].T.inverse() * est[pairs[b].second].T;
    r.t.push_back(ref[pairs[b].first].t);
    r.errors.push_back((dr.inverse() * de).translation().norm());
  };
  if (!delta_in_metres) {
    const auto step = static_cast<std::size_t>(std::llround(delta));
    if (step == 0 || std::fabs(delta - static_cast<double>(step)) > 1e-9)
      throw std::invalid_argument("--delta in frames must be a whole number");
    for (std::size_t a = 0; a + step < pairs.size(); a += step) error(a, a + step);
  } else {
    std::size_t a = 0;
    double travelled = 0;
    for (std::size_t b = 1; b < pairs.size(); ++b) {
      const Trajectory& along = pairs_from_reference ? ref : est;
      const std::size_t k1 = pairs_from_reference ? pairs[b].first : pairs[b].second;
      const std::size_t k0 = pairs_from_reference ? pairs[b - 1].first : pairs[b - 1].second;
      travelled += (along[k1].T.translation() - along[k0].T.translation()).norm();
      if (travelled >= delta) {
        error(a, b);
        a = b;
        travelled = 0;
      }
    }
  }
  r.stats = statistics(r.errors);
  return r;
}

double pathLength(const Trajectory& ref, const std::vector<std::pair<std::size_t, std::size_t>>& pairs) {
  double len = 0;
  for (std::size_t k = 1; k < pairs.size(); ++k) {
    len += (ref[pairs[k].first].T.translation() - ref[pairs[k - 1].first].T.translation()).norm();
  }
  return len;
}

Trajectory heldAtLastPose(const Trajectory& est, const std::vector<double>& times, double max_dt) {
  Trajectory out;
  if (est.empty()) return out;
  out.reserve(times.size());
  std::size_t k = 0;  // the first pose of est after times[i] + max_dt
  for (const double t : times) {
    while (k < est.size() && est[k].t <= t + max_dt) ++k;
    out.push_back({t, est[k == 0 ? 0 : k - 1].T});
  }
  return out;
}

}  // namespace rvwo::apps
