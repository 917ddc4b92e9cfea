// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Trajectories for the apps: TUM-format files ("t x y z qx qy qz qw", '#' comments), association
// by nearest timestamp, alignment, and the error metrics of the field's standard tool, evo:
//
//   ATE (evo_ape, translation part): e_i = | p_ref,i - (s R p_est,i + t) | after aligning
//        se3   Umeyama, no scale (evo --align)          sim3  Umeyama with scale (--align --correct_scale)
//        posyaw  rotation about z only, plus translation (rpg_trajectory_evaluation's "posyaw")
//        none    as they are
//   RPE (evo_rpe, translation part): for pairs (i, j) a fixed delta apart, with E =
//        (T_ref,i^-1 T_ref,j)^-1 (T_est,i^-1 T_est,j), e = |trans(E)|. Pairs as evo forms them
//        without --all_pairs: i = 0, delta, 2 delta, ... for a frame delta; for a distance delta,
//        from each i the first j whose path length reaches delta, the next i being j, the path
//        being the estimate's (evo's default) or the reference's (evo --pairs_from_reference).
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace rvwo::apps {

struct StampedPose {
  double t = 0.0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();  // T_w_b
};
using Trajectory = std::vector<StampedPose>;

// Reads a TUM file. Separator: spaces or commas. Lines "key: value" are metadata (OpenLORIS:
// "scene: home"); each "seq: N" line starts a block. block 0 reads every pose, block k >= 1 only
// those of the k-th block. Throws std::runtime_error "<file>:<line>: <what>".
// lenient: rows whose timestamp does not increase (real recordings repeat some) are skipped
// instead of being an error.
Trajectory readTum(const std::string& path, int block = 0, bool lenient = false);
// Writes it (full precision), whole or not at all (writeWhole); throws std::runtime_error when
// the file cannot be written.
void writeTum(const std::string& path, const Trajectory& trajectory);

// Nearest-timestamp pairs (ref index, est index) within max_dt seconds, each est used once,
// in ref order.
std::vector<std::pair<std::size_t, std::size_t>> associate(const Trajectory& ref, const Trajectory& est, double max_dt);

enum class Alignment { kSE3, kSim3, kPosYaw, kNone };
Alignment parseAlignment(const std::string& name);  // "se3", "sim3", "posyaw", "none"

struct Similarity {
  double s = 1.0;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  Eigen::Vector3d apply(const Eigen::Vector3d& p) const { return s * R * p + t; }
};
// The transform that maps est positions onto ref positions (paired by index).
Similarity align(const std::vector<Eigen::Vector3d>& ref, const std::vector<Eigen::Vector3d>& est, Alignment mode);

struct ErrorStats {
  double rmse = 0, mean = 0, median = 0, std = 0, min = 0, max = 0;
  std::size_t n = 0;
};
ErrorStats statistics(const std::vector<double>& errors);

struct AteResult {
  ErrorStats stats;
  Similarity alignment;
  std::vector<double> t, errors;                  // per pair: ref time, error [m]
  std::vector<Eigen::Vector3d> ref, est_aligned;  // per pair
};
AteResult ate(const Trajectory& ref, const Trajectory& est,
              const std::vector<std::pair<std::size_t, std::size_t>>& pairs, Alignment mode);

struct RpeResult {
  ErrorStats stats;
  std::vector<double> t, errors;
};
// delta in frames (delta_in_metres false) or metres; on the associated pairs. The RPE does not
// depend on a global alignment of the trajectories.
RpeResult rpe(const Trajectory& ref, const Trajectory& est,
              const std::vector<std::pair<std::size_t, std::size_t>>& pairs, double delta, bool delta_in_metres,
              bool pairs_from_reference = false);

// Path length of the reference over the associated poses (for "% of path").
double pathLength(const Trajectory& ref, const std::vector<std::pair<std::size_t, std::size_t>>& pairs);

// A pose at each of times (increasing): the estimate's own where it has one within max_dt, else
// the last one before (a system that lost track: what its user had), before its first its first.
// For an ATE over every frame of a run that did not keep them all. Empty when est is.
Trajectory heldAtLastPose(const Trajectory& est, const std::vector<double>& times, double max_dt);

}  // namespace rvwo::apps
