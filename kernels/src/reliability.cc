// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/kernels/reliability.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace rvwo {
namespace {

struct Key {
  const char* name;
  double ReliabilityParams::*member;
};
const Key kKeys[] = {
    {"Reliability.Lambda1", &ReliabilityParams::lambda1},
    {"Reliability.Lambda2", &ReliabilityParams::lambda2},
    {"Reliability.InitialPs", &ReliabilityParams::initial_ps},
    {"Reliability.Eth", &ReliabilityParams::e_th},
    {"Reliability.Emax", &ReliabilityParams::e_max},
    {"Reliability.Ws", &ReliabilityParams::w_s},
    {"Reliability.Wo", &ReliabilityParams::w_o},
    {"Reliability.Ph", &ReliabilityParams::p_h},
    {"Reliability.a", &ReliabilityParams::a},
    {"Reliability.b", &ReliabilityParams::b},
    {"Reliability.c", &ReliabilityParams::c},
};

[[noreturn]] void bad(const char* key, const std::string& why) {
  throw std::invalid_argument(std::string("Reliability.") + key + ": " + why);
}
bool probability(double v) { return v >= 0.0 && v <= 1.0; }

}  // namespace

void ReliabilityParams::validate() const {
  if (!probability(lambda1)) bad("Lambda1", "must be a probability in [0, 1]");
  if (!probability(lambda2)) bad("Lambda2", "must be a probability in [0, 1]");
  if (!probability(initial_ps)) bad("InitialPs", "must be a probability in [0, 1]");
  if (!(e_th >= 0.0 && std::isfinite(e_th))) bad("Eth", "must be finite and >= 0");
  if (!(e_max > e_th && std::isfinite(e_max))) bad("Emax", "must be finite and > Reliability.Eth");
  if (!probability(w_s)) bad("Ws", "must be in [0, 1]");
  if (!probability(w_o)) bad("Wo", "must be in [0, 1]");
  if (std::fabs(w_s + w_o - 1.0) > 1e-9) bad("Wo", "Reliability.Ws + Reliability.Wo must be 1");
  if (!probability(p_h)) bad("Ph", "must be in [0, 1]");
  if (!(std::isfinite(a) && std::isfinite(b) && std::isfinite(c))) bad("a", "a, b, c must be finite");
}

const std::vector<std::string>& ReliabilityParams::keys() {
  static const std::vector<std::string> k = [] {
    std::vector<std::string> v;
    for (const Key& key : kKeys) v.emplace_back(key.name);
    return v;
  }();
  return k;
}

bool ReliabilityParams::set(std::string_view key, double value) {
  for (const Key& k : kKeys) {
    if (key == k.name) {
      this->*k.member = value;
      return true;
    }
  }
  return false;
}

std::optional<double> ReliabilityParams::get(std::string_view key) const {
  for (const Key& k : kKeys) {
    if (key == k.name) return this->*k.member;
  }
  return std::nullopt;
}

double predictMoving(double ps_previous, const ReliabilityParams& p) {  // eq. 4
  return p.lambda1 * ps_previous + p.lambda2 * (1.0 - ps_previous);
}

double updateMoving(double p_predicted, double semantic_prior) {  // eq. 5, eta written out
  const double moving = semantic_prior * p_predicted;
  const double still = (1.0 - semantic_prior) * (1.0 - p_predicted);
  const double eta = moving + still;
  // eta = 0 only for contradictory certainties (prior 1 on a surely static landmark or vice
  // versa); keep the prediction then rather than divide by zero.
  return eta > 0.0 ? moving / eta : p_predicted;
}

double outlierProbability(double e, const ReliabilityParams& p) {  // eq. 6, clamped below e_th
  return std::clamp((e - p.e_th) / (p.e_max - p.e_th), 0.0, 1.0);
}

double reliability(double ps, double po, const ReliabilityParams& p) {  // eq. 7
  return 1.0 - (p.w_s * ps + p.w_o * po);
}

double shapeFromReliability(double pr, const ReliabilityParams& p) {  // eq. 7
  const double u = 1.0 - pr;
  if (u > p.p_h) return -std::numeric_limits<double>::infinity();
  return (p.a * u + p.b) * u + p.c;
}

void LandmarkReliabilityFilter::observeLabel(double semantic_prior, const ReliabilityParams& p) {
  state_.ps = updateMoving(predictMoving(state_.ps, p), semantic_prior);
  ++state_.labelled;
  refresh(p);
}

void LandmarkReliabilityFilter::observeError(double e, const ReliabilityParams& p) {
  // A NaN error (a failed projection) counts as a gross outlier, never as a good measurement.
  state_.po = std::isnan(e) ? 1.0 : outlierProbability(e, p);
  refresh(p);
}

void LandmarkReliabilityFilter::refresh(const ReliabilityParams& p) {
  state_.pr = reliability(state_.ps, state_.po, p);
  state_.alpha = shapeFromReliability(state_.pr, p);
}

ReliabilityManager::ReliabilityManager(const ReliabilityParams& params)
    : params_(params), fresh_alpha_(LandmarkReliabilityFilter(params).state().alpha) {
  params_.validate();
}

ReliabilityManager::Shard& ReliabilityManager::shard(std::uint64_t id) const {
  // Fibonacci hashing: consecutive ids (the usual case) spread over all shards.
  return shards_[(id * 0x9E3779B97F4A7C15ull) >> 58];
}

LandmarkReliability ReliabilityManager::observe(std::uint64_t id, std::optional<double> semantic_prior,
                                                std::optional<double> whitened_error) {
  Shard& s = shard(id);
  std::lock_guard<std::mutex> lock(s.mutex);
  auto it = s.map.try_emplace(id, params_).first;
  if (semantic_prior) it->second.observeLabel(*semantic_prior, params_);
  if (whitened_error) it->second.observeError(*whitened_error, params_);
  return it->second.state();
}

std::optional<LandmarkReliability> ReliabilityManager::get(std::uint64_t id) const {
  const Shard& s = shard(id);
  std::lock_guard<std::mutex> lock(s.mutex);
  auto it = s.map.find(id);
  if (it == s.map.end()) return std::nullopt;
  return it->second.state();
}

double ReliabilityManager::alpha(std::uint64_t id) const {
  const auto st = get(id);
  return st ? st->alpha : fresh_alpha_;
}

void ReliabilityManager::forget(std::uint64_t id) {
  Shard& s = shard(id);
  std::lock_guard<std::mutex> lock(s.mutex);
  s.map.erase(id);
}

std::size_t ReliabilityManager::size() const {
  std::size_t n = 0;
  for (const Shard& s : shards_) {
    std::lock_guard<std::mutex> lock(s.mutex);
    n += s.map.size();
  }
  return n;
}

}  // namespace rvwo
