// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "convert/lists.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace rvwo::apps {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> splitFields(std::string line) {
  for (char& c : line) {
    if (c == ',' || c == '\t') c = ' ';
  }
  std::istringstream in(line);
  std::vector<std::string> out;
  for (std::string f; in >> f;) out.push_back(f);
  return out;
}

bool number(const std::string& s, double* v) {
  char* end = nullptr;
  *v = std::strtod(s.c_str(), &end);
  return !s.empty() && *end == '\0' && std::isfinite(*v);
}

// Each line of `file` that holds fields (blank lines and '#' comments skipped), with its "file:line".
template <typename Row>
void forEachRow(const fs::path& file, std::ifstream& in, Row&& row) {
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    const auto f = splitFields(line);
    if (f.empty() || f[0][0] == '#') continue;
    row(file.string() + ":" + std::to_string(n), f);
  }
}

// odometry.csv's columns: a header line naming them, each among these, in any order; without one
// (or with a header of other names), t, x, y, theta.
const std::vector<std::string> kOdometryColumns = {"t", "x", "y", "theta", "left_angle", "right_angle", "v", "omega"};

std::vector<int> namedColumns(const std::vector<std::string>& header, const std::string& where) {
  std::vector<int> col;
  for (const std::string& h : header) {
    const auto it = std::find(kOdometryColumns.begin(), kOdometryColumns.end(), h);
    if (it == kOdometryColumns.end()) return {0, 1, 2, 3};  // another header: the old layout
    col.push_back(static_cast<int>(it - kOdometryColumns.begin()));
  }
  auto has = [&](int c) { return std::find(col.begin(), col.end(), c) != col.end(); };
  const bool pose = has(1) && has(2) && has(3), angles = has(4) && has(5), twist = has(6) && has(7);
  if (!has(0) || (has(1) || has(2) || has(3)) != pose || has(4) != angles || has(5) != angles || has(6) != twist ||
      has(7) != twist || !(pose || angles || twist))
    fail(where, "columns: t, and x,y,theta (pose) and/or left_angle,right_angle (rad) and/or v,omega (m/s, rad/s)");
  return col;
}

}  // namespace

[[noreturn]] void fail(const std::string& where, const std::string& what) {
  throw std::runtime_error(where + ": " + what);
}

// "t path" lists (TUM rgb.txt, OpenLORIS color.txt, ...): '#' comments; paths relative to the folder.
std::vector<Entry> readList(const fs::path& folder, const std::string& name, bool required) {
  const fs::path file = folder / name;
  std::ifstream in(file);
  if (!in) {
    if (required) fail(file.string(), "not found");
    return {};
  }
  std::vector<Entry> out;
  forEachRow(file, in, [&](const std::string& where, const std::vector<std::string>& f) {
    double t;
    if (f.size() < 2 || !number(f[0], &t)) fail(where, "expected 'timestamp path'");
    const fs::path p = folder / f[1];
    if (!fs::is_regular_file(p)) fail(where, "image '" + f[1] + "' not found");
    if (!out.empty() && !(t > out.back().t)) fail(where, "timestamps must increase");
    out.push_back({t, fs::absolute(p).string(), where});
  });
  if (out.empty()) fail(file.string(), "no entries");
  return out;
}

// odom.txt (OpenLORIS: t x y z qx qy qz qw [twist]).
std::vector<Odometry> readOpenLorisOdometry(const fs::path& file) {
  std::ifstream in(file);
  if (!in) fail(file.string(), "not found");
  std::vector<Odometry> out;
  forEachRow(file, in, [&](const std::string& where, const std::vector<std::string>& f) {
    double v[8];
    bool ok = f.size() >= 8;
    for (std::size_t i = 0; ok && i < 8; ++i) ok = number(f[i], &v[i]);
    if (!ok) fail(where, "expected 't x y z qx qy qz qw ...'");
    Odometry o;
    o.t = v[0];
    o.x = v[1];
    o.y = v[2];
    o.theta = 2 * std::atan2(v[6], v[7]);  // yaw of a planar pose (qx, qy ~ 0)
    if (!out.empty() && !(o.t > out.back().t)) fail(where, "odometry timestamps must increase");
    out.push_back(o);
  });
  if (out.empty()) fail(file.string(), "no odometry");
  return out;
}

// odometry.csv: the odometry's pose, wheel angles or speeds, by its header (kOdometryColumns).
std::vector<Odometry> readOdometryCsv(const fs::path& file) {
  std::ifstream in(file);
  if (!in) fail(file.string(), "not found");
  std::vector<Odometry> out;
  std::vector<int> col = {0, 1, 2, 3};
  bool header = false, pose = true, angles = false, twist = false;
  forEachRow(file, in, [&](const std::string& where, const std::vector<std::string>& f) {
    double v[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    if (!header && out.empty() && !number(f[0], &v[0])) {
      header = true;
      col = namedColumns(f, where);
      const auto has = [&](int c) { return std::find(col.begin(), col.end(), c) != col.end(); };
      pose = has(1), angles = has(4), twist = has(6);
      return;
    }
    bool ok = f.size() >= col.size();
    for (std::size_t i = 0; ok && i < col.size(); ++i) ok = number(f[i], &v[col[i]]);
    if (!ok) {
      std::string names;
      for (int c : col) names += (names.empty() ? "" : ",") + kOdometryColumns[c];
      fail(where, "expected '" + names + "' (numbers)");
    }
    Odometry o;
    o.t = v[0];
    o.x = v[1];
    o.y = v[2];
    o.theta = v[3];
    o.pose = pose;
    o.angles = angles;
    o.twist = twist;
    if (o.angles) {
      const double k = kTicksPerRevolution / (2 * M_PI), l = std::round(v[4] * k), r = std::round(v[5] * k);
      if (std::fabs(l) > INT32_MAX || std::fabs(r) > INT32_MAX)
        fail(where, "a wheel angle beyond what 32-bit encoder ticks hold (" + std::to_string(INT32_MAX / k) + " rad)");
      o.ticks_left = static_cast<std::int32_t>(l);
      o.ticks_right = static_cast<std::int32_t>(r);
    }
    o.v = v[6];
    o.omega = v[7];
    if (!out.empty() && !(o.t > out.back().t)) fail(where, "odometry timestamps must increase");
    out.push_back(o);
  });
  if (out.empty()) fail(file.string(), "no odometry");
  return out;
}

}  // namespace rvwo::apps
