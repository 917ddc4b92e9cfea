// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Landmark reliability (RVWO paper eqs. 4 to 7; docs/maths.md section 2) and the Barron shape it
// selects. Per landmark:
//
//   predict (eq. 4)  P-  = l1 * Ps + l2 * (1 - Ps)
//   update  (eq. 5)  Ps  = Pp * P- / (Pp * P- + (1 - Pp) * (1 - P-))      Pp = prior of the label
//   outlier (eq. 6)  Po  = clamp((e - e_th) / (e_max - e_th), 0, 1)       e = sqrt(chi2)
//   eq. 7            Pr  = 1 - (ws * Ps + wo * Po),  u = 1 - Pr
//                    alpha = a u^2 + b u + c   if u <= Ph,   -inf otherwise
//
// Slips in the paper handled here: eta of eq. 5 is the two-hypothesis normaliser written out
// above; eq. 6 as printed uses |e - e_th| and so gives a rising outlier probability for errors
// below e_th, we clamp at 0 instead; the constant term of eq. 7 is called c like Barron's scale,
// here it is `c` in ReliabilityParams and has nothing to do with BarronKernel::c().
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace rvwo {

struct ReliabilityParams {
  // ---- Bayes filter on "this landmark moves" (eqs. 4, 5). Settings: Reliability.<Name>.
  // Lambda1: P(moving now | moving at the previous observation). People who move keep moving
  // between keyframes a few tenths of a second apart, though they do stop: 0.95. Lower values
  // make the filter forget fast: with 0.9, one missed person label (a segmentation miss, ~10 %
  // of frames) drops a walker from Ps = 0.99 to 0.48 and hands it back to the map.
  double lambda1 = 0.95;
  // Lambda2: P(moving now | static at the previous observation). Static structure rarely starts
  // to move; kept small but non-zero so that a parked object that drives off can be caught.
  double lambda2 = 0.01;
  // InitialPs: P_s before the first labelled observation. 0: a landmark is static until evidence
  // says otherwise (the usual SLAM assumption), so a fresh landmark gets alpha = 1 exactly; the
  // first prediction already lifts it to Lambda2, so the evidence of labels is never locked out.
  // (An unlabelled landmark is never predicted, so it keeps alpha = 1.)
  double initial_ps = 0.0;
  // ---- Outlier probability (eq. 6), in whitened units e = sqrt(chi2), so the thresholds hold
  // for any pixel noise. Eth = sqrt(5.991): 95 % of 2-DoF inliers lie below it (ORB-SLAM's
  // chi2 gate); Emax = 6 = sqrt(36): an inlier reaches it with probability exp(-18).
  double e_th = 2.447746830680816;
  double e_max = 6.0;
  // ---- Weights (eq. 7), Ws + Wo = 1. The semantic channel must be able to reject a landmark by
  // itself: with Ph = 0.9 a landmark seen as a person (Ps -> 0.99) is cut at u > 0.9 only if
  // Ws > 0.91. Ws = 0.95 rejects after three consistent person labels (Ps = 0.983, u = 0.933),
  // while two (Ps = 0.785, alpha = -4.9) already weigh it down and one (Ps = 0.16, alpha = 0.51)
  // only softens it, so a single mislabelled frame does not throw a landmark away. The
  // reprojection channel then moves alpha by at most Wo = 0.05 in u (from 1 to 0.88): the error
  // itself is already down-weighted by the kernel. The paper leaves both unstated; the authors'
  // code used 0.5 / 0.5, with which Ph = 0.9 could never reject on semantics alone.
  double w_s = 0.95;
  double w_o = 0.05;
  // ---- Shape (eq. 7), the paper's values: alpha(0) = 1, alpha(0.5) = -2, alpha(0.9) = -7.28.
  double p_h = 0.9;
  double a = -8.0;
  double b = -2.0;
  double c = 1.0;

  // Throws std::invalid_argument naming the settings key of the first inconsistent value.
  void validate() const;
  // Settings keys ("Reliability.Lambda1", ...), in declaration order.
  static const std::vector<std::string>& keys();
  // Sets the member of a settings key; false if the key is not one of keys().
  bool set(std::string_view key, double value);
  std::optional<double> get(std::string_view key) const;
};

// Eq. 4: predicted probability of motion at the next observation.
double predictMoving(double ps_previous, const ReliabilityParams& p);
// Eq. 5 (eta written out): posterior from the predicted probability and the label's prior.
double updateMoving(double p_predicted, double semantic_prior);
// Eq. 6, clamped to [0, 1]. e: whitened reprojection error sqrt(chi2), >= 0.
double outlierProbability(double e, const ReliabilityParams& p);
// Eq. 7: reliability Pr = 1 - (ws Ps + wo Po).
double reliability(double ps, double po, const ReliabilityParams& p);
// Eq. 7: Barron shape from reliability; -inf when u = 1 - Pr > Ph.
double shapeFromReliability(double pr, const ReliabilityParams& p);

struct LandmarkReliability {
  double ps = 0.0;             // probability that it moves (filtered)
  double po = 0.0;             // outlier probability from the latest reprojection error
  double pr = 1.0;             // reliability
  double alpha = 1.0;          // Barron shape for its residuals
  std::uint32_t labelled = 0;  // labelled observations so far
};

// One landmark's filter state.
class LandmarkReliabilityFilter {
 public:
  explicit LandmarkReliabilityFilter(const ReliabilityParams& p) {
    state_.ps = p.initial_ps;
    refresh(p);
  }
  // A frame labelled the landmark with a class of this prior (eqs. 4, 5).
  void observeLabel(double semantic_prior, const ReliabilityParams& p);
  // A new whitened reprojection error (eq. 6).
  void observeError(double e, const ReliabilityParams& p);
  const LandmarkReliability& state() const { return state_; }

 private:
  void refresh(const ReliabilityParams& p);
  LandmarkReliability state_;
};

// Reliability of every live landmark, keyed by landmark id. Safe to call from several threads at
// once (tracking and mapping): the map is split into shards, each behind its own mutex, so
// threads touching different landmarks rarely contend. O(1) expected per call. Landmarks that
// are culled should be forgotten, so memory follows the live map.
class ReliabilityManager {
 public:
  explicit ReliabilityManager(const ReliabilityParams& params = {});

  // An observation: the label's semantic prior (std::nullopt when the frame was not segmented)
  // and the whitened reprojection error (std::nullopt when not measured). Returns the new state.
  LandmarkReliability observe(std::uint64_t id, std::optional<double> semantic_prior,
                              std::optional<double> whitened_error);
  // Current state; std::nullopt for a landmark never observed (or forgotten).
  std::optional<LandmarkReliability> get(std::uint64_t id) const;
  // Current Barron shape; for an unknown landmark, that of a fresh one (1 with the defaults).
  double alpha(std::uint64_t id) const;
  void forget(std::uint64_t id);
  std::size_t size() const;
  const ReliabilityParams& params() const { return params_; }

 private:
  static constexpr std::size_t kShards = 64;
  struct Shard {
    mutable std::mutex mutex;
    std::unordered_map<std::uint64_t, LandmarkReliabilityFilter> map;
  };
  Shard& shard(std::uint64_t id) const;
  const ReliabilityParams params_;
  double fresh_alpha_;
  mutable std::array<Shard, kShards> shards_;
};

}  // namespace rvwo
