// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "people.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace rvwo::embedded {
struct File {
  const uint8_t* data;
  std::size_t size;
};
extern const File people_files[];
extern const std::size_t people_count;
}  // namespace rvwo::embedded

namespace rvwo::sim {
namespace {

// Each image's height in metres, as photographed: its height in pixels times the person's median
// depth over fr3's fy (539.2 px). person_0: standing, 454 px at 1.349 m, cut at the shins;
// person_1: sitting, 349 px at 1.993 m.
constexpr double kMetres[] = {454 * 1.349 / 539.2, 349 * 1.993 / 539.2};

std::vector<Person> decode() {
  std::vector<Person> out;
  for (std::size_t i = 0; i < embedded::people_count; ++i) {
    const embedded::File& f = embedded::people_files[i];
    const cv::Mat bytes(1, static_cast<int>(f.size), CV_8U, const_cast<uint8_t*>(f.data));
    const cv::Mat bgra = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
    if (bgra.empty() || bgra.channels() != 4 || i >= std::size(kMetres)) {
      throw std::runtime_error("rvwo-sim: person " + std::to_string(i) +
                               " compiled in is not a colour image with alpha");
    }
    Person p;
    cv::cvtColor(bgra, p.grey, cv::COLOR_BGRA2GRAY);
    cv::extractChannel(bgra, p.alpha, 3);
    p.metres = kMetres[i];
    out.push_back(p);
  }
  return out;
}

}  // namespace

const std::vector<Person>& people() {
  static const std::vector<Person> all = decode();
  return all;
}

}  // namespace rvwo::sim
