// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Semantic priors: for each class of a segmentation network's label set, P_prior, the
// probability that a point with that label moves (RVWO paper eq. 5, person 0.95). Built-in tables
// for PASCAL VOC-21 ("voc21"), COCO-80 ("coco80") and ADE20K-150 ("ade20k150", the paper's
// SegFormer); the reason for every value is written beside the tables in semantic_priors.cc.
// Any entry can be overridden, by code or by a text stream of "class: prior" lines.
#pragma once

#include <cstddef>
#include <iosfwd>
#include <string>
#include <string_view>
#include <vector>

namespace rvwo {

class SemanticPriors {
 public:
  // Prior for a label outside the set (or "no label"): 0.5, no evidence either way.
  static constexpr double kNoEvidence = 0.5;

  // One of builtinNames(); throws std::invalid_argument listing them otherwise.
  static SemanticPriors builtin(std::string_view name);
  static std::vector<std::string> builtinNames();

  // A custom set: class names (label id = index) and their priors, each in [0, 1].
  SemanticPriors(std::string name, std::vector<std::string> classes, std::vector<double> priors);

  const std::string& name() const { return name_; }
  std::size_t size() const { return classes_.size(); }
  const std::vector<std::string>& classes() const { return classes_; }
  const std::string& className(int label) const;   // throws std::out_of_range
  int labelOf(std::string_view class_name) const;  // -1 when not in the set
  double prior(int label) const {
    return label >= 0 && static_cast<std::size_t>(label) < priors_.size() ? priors_[label] : kNoEvidence;
  }
  // Throws std::invalid_argument for an unknown class or a prior outside [0, 1].
  void set(std::string_view class_name, double prior);
  // Lines "class_name: prior"; blank lines and '#' comments ignored. Errors throw
  // std::invalid_argument as "<source>:<line>: <what>".
  void overrideFrom(std::istream& in, const std::string& source = "<stream>");
  // Labels whose prior is above the threshold (the classes to dilate around, to draw, ...).
  std::vector<int> dynamicLabels(double threshold = 0.5) const;

 private:
  std::string name_;
  std::vector<std::string> classes_;
  std::vector<double> priors_;
};

}  // namespace rvwo
