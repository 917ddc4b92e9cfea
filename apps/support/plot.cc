// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "support/output.h"

namespace rvwo::apps {
namespace {

const mrpt::img::TColor kBlack(0, 0, 0), kGrid(225, 225, 225), kWhite(255, 255, 255);

// A "nice" tick step (1, 2 or 5 times a power of ten) for about n ticks over span.
double tickStep(double span, int n) {
  const double raw = span / n, p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * p >= raw) return m * p;
  }
  return 10 * p;
}

std::string number(double v, double step) {
  char buf[32];
  const int digits = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
  std::snprintf(buf, sizeof buf, "%.*f", digits, std::fabs(v) < 1e-12 ? 0.0 : v);
  return buf;
}

}  // namespace

void Plot::add(std::vector<Eigen::Vector2d> points, mrpt::img::TColor colour, std::string label, int width) {
  series_.push_back({std::move(points), colour, std::move(label), width});
}

void Plot::draw(mrpt::img::CImage& img, int x0, int y0, int w, int h) const {
  img.filledRectangle(x0, y0, x0 + w - 1, y0 + h - 1, kWhite);
  const int left = x0 + 70, right = x0 + w - 20, top = y0 + 34, bottom = y0 + h - 46;
  Eigen::Vector2d lo(std::numeric_limits<double>::max(), std::numeric_limits<double>::max()), hi = -lo;
  for (const Series& s : series_) {
    for (const Eigen::Vector2d& p : s.points) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  }
  if (lo.x() > hi.x()) lo.setZero(), hi.setOnes();
  for (int k = 0; k < 2; ++k) {
    if (hi[k] - lo[k] < 1e-9) lo[k] -= 0.5, hi[k] += 0.5;
    const double pad = 0.04 * (hi[k] - lo[k]);
    lo[k] -= pad;
    hi[k] += pad;
  }
  double sx = (right - left) / (hi.x() - lo.x()), sy = (bottom - top) / (hi.y() - lo.y());
  if (equal_) {  // one scale for both axes, centred
    const double s = std::min(sx, sy);
    const Eigen::Vector2d c = 0.5 * (lo + hi), half((right - left) / (2 * s), (bottom - top) / (2 * s));
    lo = c - half;
    hi = c + half;
    sx = sy = s;
  }
  auto px = [&](const Eigen::Vector2d& p) {
    return Eigen::Vector2i(static_cast<int>(std::lround(left + (p.x() - lo.x()) * sx)),
                           static_cast<int>(std::lround(bottom - (p.y() - lo.y()) * sy)));
  };
  // Grid, ticks and their numbers.
  const double tx = tickStep(hi.x() - lo.x(), 8), ty = tickStep(hi.y() - lo.y(), 6);
  for (double v = std::ceil(lo.x() / tx) * tx; v <= hi.x(); v += tx) {
    const int x = px({v, lo.y()}).x();
    img.line(x, top, x, bottom, kGrid, 1);
    const std::string s = number(v, tx);
    img.textOut(x - 4 * static_cast<int>(s.size()), bottom + 6, s, kBlack);
  }
  for (double v = std::ceil(lo.y() / ty) * ty; v <= hi.y(); v += ty) {
    const int y = px({lo.x(), v}).y();
    img.line(left, y, right, y, kGrid, 1);
    const std::string s = number(v, ty);
    img.textOut(left - 8 - 8 * static_cast<int>(s.size()), y - 6, s, kBlack);
  }
  img.rectangle(left, top, right, bottom, kBlack, 1);
  img.textOut(x0 + 10, y0 + 2, title_, kBlack);
  img.textOut((left + right) / 2 - 4 * static_cast<int>(x_label_.size()), bottom + 24, x_label_, kBlack);
  img.textOut(x0 + 6, top - 14, y_label_, kBlack);
  for (const Series& s : series_) {
    for (std::size_t i = 0; i < s.points.size(); ++i) {
      const Eigen::Vector2i a = px(s.points[i]);
      if (s.width == 0) {
        img.drawCircle(a.x(), a.y(), 1, s.colour);
      } else if (i + 1 < s.points.size()) {
        const Eigen::Vector2i b = px(s.points[i + 1]);
        img.line(a.x(), a.y(), b.x(), b.y(), s.colour, s.width);
      }
    }
  }
  int row = 0;  // legend, top right
  for (const Series& s : series_) {
    if (s.label.empty()) continue;
    const int y = top + 8 + 18 * row++, x = right - 12 - 9 * static_cast<int>(s.label.size()) - 28;
    img.filledRectangle(x, y, x + 18, y + 10, s.colour);
    img.textOut(x + 24, y - 2, s.label, kBlack);
  }
}

void Plot::save(const std::string& path, int w, int h) const { savePanels(path, {this}, w, h); }

void savePanels(const std::string& path, const std::vector<const Plot*>& panels, int w, int panel_h) {
  mrpt::img::CImage img(w, panel_h * static_cast<int>(panels.size()), mrpt::img::CH_RGB);
  for (std::size_t i = 0; i < panels.size(); ++i) panels[i]->draw(img, 0, static_cast<int>(i) * panel_h, w, panel_h);
  writeWhole(path, [&](const std::string& tmp) {
    if (!img.saveToFile(tmp)) throw std::runtime_error("cannot write '" + path + "'");
  });
}

}  // namespace rvwo::apps
