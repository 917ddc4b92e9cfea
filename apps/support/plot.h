// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Line plots for the apps' PNG output, drawn with mrpt::img: axes with ticks and labels, series
// with a legend, optionally equal axis scales (for trajectories seen from above). Several plots
// can share one image as panels.
#pragma once

#include <mrpt/img/CImage.h>

#include <Eigen/Core>
#include <string>
#include <vector>

namespace rvwo::apps {

class Plot {
 public:
  Plot(std::string title, std::string x_label, std::string y_label, bool equal_axes = false)
      : title_(std::move(title)), x_label_(std::move(x_label)), y_label_(std::move(y_label)), equal_(equal_axes) {}
  // A polyline (width > 0) or dots (width 0).
  void add(std::vector<Eigen::Vector2d> points, mrpt::img::TColor colour, std::string label, int width = 2);
  // Draws into the rectangle (x0, y0, w, h) of the image.
  void draw(mrpt::img::CImage& image, int x0, int y0, int w, int h) const;
  // One panel, one file; throws std::runtime_error when it cannot be written.
  void save(const std::string& path, int w = 1000, int h = 760) const;

 private:
  struct Series {
    std::vector<Eigen::Vector2d> points;
    mrpt::img::TColor colour;
    std::string label;
    int width;
  };
  std::string title_, x_label_, y_label_;
  bool equal_;
  std::vector<Series> series_;
};

// Saves panels stacked vertically in one PNG; throws std::runtime_error on failure.
void savePanels(const std::string& path, const std::vector<const Plot*>& panels, int w = 1000, int panel_h = 560);

}  // namespace rvwo::apps
