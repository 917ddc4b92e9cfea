// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The tracker, frame by frame: predict from the wheels, match the local map, solve the pose and
// let the frame arbiter (rvwo::FrameArbiter) judge the wheels against vision, relocalise a frame
// still blind, hold after a slip, then keep the pose and make a keyframe if one is due. Runs on
// the thread that adds frames. Private to the library.
#pragma once

#include <cstddef>
#include <functional>
#include <future>
#include <optional>
#include <vector>

#include "front_end.h"
#include "map.h"
#include "mapper.h"
#include "rvwo/tracking/frame_arbiter.h"
#include "wheels.h"

namespace rvwo::estimator {

class Tracker {
 public:
  Tracker(Context& ctx, Map& map, Wheels& wheels, Mapper& mapper, const FrontEnd& front_end);

  // The frame's pipeline; its features are made here unless the front end's thread made them.
  void processFrame(const FrameInput& in, std::future<FrameFeatures> features = {});

  std::size_t slipFrames() const { return slip_frames_; }  // frames where vision overruled the wheels
  void setCallback(std::function<void(const PoseEstimate&)> callback) { callback_ = std::move(callback); }

  // The frame arbiter's preset for the rig, with what the options set (its bars, the kernel's
  // wheel gate) and the creep test where keyframes get labels.
  static ArbiterOptions arbiterOptions(const Rig& r, const EstimatorOptions& o, bool labelled);

 private:
  // One frame's tracking as it goes through the steps of processFrame.
  struct FrameWork {
    double t = 0;
    std::optional<WheelDelta> delta;  // the wheels since the last frame (none: vo, or no readings)
    SE2 predicted;                    // where they (or the motion model) put the robot
    Features f;
    cv::Mat raw_image;
    Eigen::Vector3d x = Eigen::Vector3d::Zero();  // the pose being solved
    std::vector<Match> matches;
    std::vector<char> inlier, trusted;  // per match
    std::vector<double> errors;         // per match: whitened error
    int inliers = 0;
    bool strained = false;  // vision strains the wheel edge from the last frame
    bool visual = false;
    bool after_slip = false, wheels_doubted = false;  // FrameOutcome's
    int countTrusted(const std::vector<char>& in) const { return rvwo::countTrusted(in, trusted); }
  };

  // The pose the wheels predict from the last frame's (refreshed from its reference keyframe,
  // which local BA may have moved), or without them the motion model's.
  void predictFrame(FrameWork* w);

  // Matches to the local map, then the frame's pose and the wheels against vision (the arbiter).
  // (Map lock held.)
  void trackLocalMap(FrameWork* w);

  // The wheels against vision for this frame (rvwo::FrameArbiter): the pose solved with the wheel
  // edge, a slip (vision alone overrules them), a stall (mono), the wheel gate (docs/decisions/0002).
  FrameEvidence frameEvidence(const FrameWork& w);
  // A slip frame: counted and marked for local BA (a spin's wheel edge sits out its first round).
  void recordSlip(double t, bool spin);

  // Still blind after a stretch on the wheels: their prediction may be too far off for the
  // projection search, the map in memory may still be in view. Stereo and RGB-D relocalise by
  // descriptor (relocalise); mono searches along the wheels' way, only while landmarks doubt them
  // (alongTheWheelsWay). Only trusted landmarks place the frame (walkers' landmarks a label has
  // seen, still inliers under their kernel, would pull the pose along); the arbiter says whether
  // the result is believed. (Map lock held.)
  void relocaliseBlindFrame(FrameWork* w);

  // Blind right after a slip, the wheels are the last to trust: the arbiter holds the pose where
  // vision left it (for at most Tracking.SlipHold), and its frames count as the spin they hold
  // (docs/decisions/0009). It also says whether the landmarks in view doubt the wheels.
  void settleFrame(FrameWork* w);

  // The frame's pose (vision's, held, or the wheels'), its landmarks' reliabilities (eq. 6), and a
  // keyframe if one is due. Returns whether one was made. (Map lock held.)
  bool keepFrame(FrameWork* w, FrameRecord* record);

  // ORB-SLAM's keyframe rules with RVWO's exceptions (docs/estimator.md, rule 11). Visual: every
  // Estimator.KeyFrameMaxFrames frames, when the reference keyframe's points are less than
  // Estimator.KeyFrameRatio tracked, or for close untracked features, but not in a slip nor while
  // vision strains the wheel edge (a keyframe made at a pose the wheels pulled along moves the map
  // with them). Blind: a keyframe at the wheels' pose restarts the map once there is texture,
  // unless it holds after a slip or the landmarks in view doubt the wheels. (Map lock held.)
  bool keyFrameDue(const FrameWork& w, const SE2& T_w_b, const std::vector<std::int64_t>& point_of,
                   const std::vector<char>& on_walker, const KeyFrame& ref_kf) const;

  // A keyframe in the map (Map::createKeyFrame), its image off to the segmenter. (Map lock held.)
  int makeKeyFrame(double t, const Eigen::Vector3d& x, Features&& f, std::vector<std::int64_t> point_of,
                   const cv::Mat& image, int tracked = 0, const std::vector<char>& no_new_point = {});

  // A relocalisation ends a blind stretch where the wheels may have been wrong (they spun while
  // vision could not see it), but only as a slip leaves them: on the way they claimed since the
  // last frame vision placed with them (onTheClaimedWay; not a slip frame, which vision alone
  // placed). (Map lock held.)
  bool onTheWheelsWay(const Eigen::Vector3d& x, double t) const;
  // The last frame vision placed (slips_too: also one vision alone placed, overruling the wheels).
  const FrameRecord* lastVisualFrame(bool slips_too) const;

  // Vision is back after a stretch on the wheels: the map says the pose is C T_wheels (C in the
  // world frame, the wheels' drift while blind). Applied to this frame alone it would be a jump;
  // the frames of the stretch take the fraction s of it (s from 0 at the last visual frame to 1
  // now, along exp(s log C)), so that the trajectory written bends instead of jumping. (Map lock
  // held.)
  void spreadCorrection(const SE2& C, double t);

  void finishFrame(const FrameRecord& record, double t);

  // ---- matching and the pose (map lock held) ----
  // count_visible: each landmark projected into the image counts as visible (for culling); a
  // search that only probes a pose leaves the counts alone.
  std::vector<Match> searchByProjection(const Features& f, const Eigen::Vector3d& x, double radius_scale,
                                        bool count_visible = true);

  // Predicted pyramid level of a point seen from distance d.
  int predictLevel(const MapPoint& p, double d) const;

  // Relocalisation against the map in memory (stereo and RGB-D), when the projection search
  // finds nothing: after a blind stretch the wheels' prediction may be far off (a slip while a
  // walker covered the view left it 0.6 rad off, and the map was started anew from there). Each
  // feature with depth is matched by descriptor with the trusted landmarks (Hamming <= 50, clearly
  // better than the second best, at the same height within 0.2 m: the robot stays on its floor);
  // two pairs fix an SE(2) pose from their ground-plane positions (RANSAC, a fixed seed); the best
  // pose, if 3 x Tracking.MinInliers pairs agree with it, seeds the projection search and the pose
  // optimisation.
  std::optional<Eigen::Vector3d> relocalise(const Features& f) const;

  // Mono's relocalisation (no depth to place features by descriptor): the map is searched from
  // poses along the way the wheels claimed since vision last placed a frame, from where it left
  // the robot (the robot stood: a slip) to three quarters of the claim (it crept); the pose with
  // the most trusted matches, at least Tracking.MinInliers, seeds the search and the pose solve.
  std::optional<Eigen::Vector3d> alongTheWheelsWay(const Features& f, double t);

  // The frame's matches as the pose solver takes them, each with its landmark's kernel.
  std::vector<PoseObservation> poseObservations(const Features& f, const std::vector<Match>& matches) const;

  // Pose-only optimisation on SE(2) (rvwo::optimisePlanarPose) with each landmark's kernel. prior:
  // the wheel edge from the previous frame (fixed) to this one.
  int optimisePose(const Features& f, const std::vector<Match>& matches, const std::optional<WheelEdge>& prior,
                   const Eigen::Vector3d& x_prev, Eigen::Vector3d* x, std::vector<char>* inlier,
                   std::vector<double>* errors) const;

  Context& ctx_;
  Map& map_;
  Wheels& wheels_;
  Mapper& mapper_;
  const FrontEnd& front_end_;
  // The wheels against vision, frame by frame (the slip, the stall, the wheel gate, the hold, the
  // relocalisation's belief).
  FrameArbiter arbiter_;
  std::function<void(const PoseEstimate&)> callback_;

  double last_t_ = -1;  // of the last processed frame
  SE2 last_pose_;       // its T_w_b (absolute, refreshed from its reference keyframe)
  SE2 velocity_;        // T_{k-1}_{k}: constant-velocity model without wheels
  int frames_since_kf_ = 0;
  bool has_last_ = false, last_visual_ = true;
  std::size_t slip_frames_ = 0;
};

}  // namespace rvwo::estimator
