// Copyright (c) 2026 the RVWO authors. GPL-3.0-or-later (plugins/orbslam3/LICENSE).
// The policy suite (tests/common/policy_scenes.h) through the ORB-SLAM3 plugin: each frame's pose
// problem as the patched Tracking hands it over (its matches to the map's points, the wheels'
// prediction, the frame before it), solved by WheelInput::optimisePose and then reported tracked.
// ORB-SLAM3's map is stood in for by the landmarks where the map first saw them: the room's where
// they are, a walker's where it stood at the last keyframe (every fifth frame).
#include <gtest/gtest.h>

#include "../common/policy_scenes.h"
#include "orbslam3_common.h"
#include "rvwo/orbslam3/wheel_input.h"

namespace {

using rvwo::orbslam3::PoseMatch;
using rvwo::orbslam3::PoseProblem;
using rvwo::orbslam3::PoseSolution;
using rvwo::orbslam3::WheelInput;
using rvwo::orbslam3::WheelInputParams;
using rvwo::orbslam3::WheelReading;
using rvwo::test::PolicyRig;
using rvwo::test::PolicyScene;

rvwo::test::PolicyOutcome replay(const PolicyScene& s) {
  const PolicyRig r;
  WheelInput w;
  WheelInputParams p;
  p.T_b_c = r.T_b_c;
  w.configure(p);
  // ORB-SLAM3's world is its first camera's frame.
  const Eigen::Isometry3d T_orb_w = r.T_b_c.inverse();
  rvwo::test::PolicyOutcome o;
  double odometry_t = 0;
  Eigen::Isometry3d T_cp_w = rvwo::test::cameraPose(s.truth(0), r.T_b_c);
  for (int i = 1; i < s.frames(r); ++i) {
    const double t = i / r.fps, t_prev = (i - 1) / r.fps;
    std::vector<WheelReading> readings;
    for (; odometry_t <= t + 0.011; odometry_t += 0.01) {
      const rvwo::SE2 x = s.claimed(odometry_t);
      readings.push_back(WheelReading::pose(odometry_t, x.translation().x(), x.translation().y(), x.angle()));
    }
    w.add(readings);
    PoseProblem pb;
    pb.t = t;
    pb.has_previous = true;
    pb.t_previous = t_prev;
    pb.T_cp_w = T_cp_w;
    pb.T_c_w = w.predict(T_cp_w, t_prev, t);
    pb.fx = pb.fy = r.fx;
    pb.cx = r.cx;
    pb.cy = r.cy;
    pb.bf = r.bf();
    pb.scale_factor = 1.2;
    const double keyframe_t = (i / 5) * 5 / r.fps;
    for (const rvwo::test::Sighting& g : s.sightings(r, t)) {
      PoseMatch m;
      m.P_w = T_orb_w * (s.isWalker(g.landmark) ? s.at(g.landmark, keyframe_t) : s.at(g.landmark, 0));
      m.u = g.u;
      m.v = g.v;
      m.u_right = g.u_right;
      m.level = 0;
      m.id = static_cast<unsigned long>(g.landmark);
      pb.matches.push_back(m);
    }
    PoseSolution sol;
    const bool solved = w.optimisePose(pb, &sol);
    const bool visual = solved && sol.inliers >= 30;
    w.frameTracked(t, visual, static_cast<int>(pb.matches.size()));
    if (solved && sol.slip) o.slip_t.push_back(t);
    o.blind += !visual;
    T_cp_w = solved ? sol.T_c_w : pb.T_c_w;
    double off_plane = 0;
    const rvwo::SE2 x = rvwo::test::robotOf(T_cp_w, r.T_b_c, &off_plane);
    o.max_error = std::max(o.max_error, (s.truth(t).inverse() * x).translation().norm());
  }
  return o;
}

class OrbSlam3Policy : public ::testing::TestWithParam<PolicyScene> {};

TEST_P(OrbSlam3Policy, DecidesAsTheSceneSays) {
  rvwo::test::expectCalls(GetParam(), rvwo::test::PolicyHost::kOrbSlam3, replay(GetParam()));
}

INSTANTIATE_TEST_SUITE_P(Scenes, OrbSlam3Policy, ::testing::ValuesIn(rvwo::test::policyScenes()),
                         [](const ::testing::TestParamInfo<PolicyScene>& i) { return i.param.name; });

}  // namespace
