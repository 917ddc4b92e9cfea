// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// Runs a Segmenter in a worker thread so that tracking never waits on the network. submit()
// never blocks: the queue is bounded and, when frames come faster than the network, the oldest
// waiting request is dropped (latest wins). Results are kept by frame id (the newest
// keep_results of them) until taken. Shutdown (destructor or shutdown()) finishes the request in
// progress, drops the rest, and joins.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "rvwo/semantics/segmenter.h"

namespace rvwo {

class AsyncSegmenter {
 public:
  struct Stats {
    std::uint64_t submitted = 0, processed = 0, dropped = 0, failed = 0;
  };

  explicit AsyncSegmenter(std::shared_ptr<Segmenter> segmenter, std::size_t queue_capacity = 2,
                          std::size_t keep_results = 64);
  ~AsyncSegmenter();
  AsyncSegmenter(const AsyncSegmenter&) = delete;
  AsyncSegmenter& operator=(const AsyncSegmenter&) = delete;

  // Queues the frame (the image is shared, not copied: do not write to it afterwards). Returns
  // false when the runner is shut down.
  bool submit(const cv::Mat& image, const FrameInfo& info);
  // The result for a frame id, if it is ready; taken out of the runner.
  std::optional<Segmentation> take(std::uint64_t id);
  // Waits up to timeout for the frame's result (for a deterministic single-thread mode and tests);
  // std::nullopt when it was dropped, failed, or is not ready in time.
  std::optional<Segmentation> waitFor(std::uint64_t id, std::chrono::milliseconds timeout);
  // True while the frame's labels may still come: queued, being segmented, or done and not yet
  // taken. False once taken, dropped, failed, shut down, or for an id never submitted (or whose
  // result was pushed out of the keep_results newest).
  bool pending(std::uint64_t id) const;
  void shutdown();
  Stats stats() const;
  std::string lastError() const;

 private:
  struct Request {
    cv::Mat image;
    FrameInfo info;
  };
  void run();

  std::shared_ptr<Segmenter> segmenter_;
  const std::size_t capacity_, keep_;
  mutable std::mutex mutex_;
  std::condition_variable work_, done_;
  std::deque<Request> queue_;
  std::optional<std::uint64_t> running_;  // the id being segmented
  std::map<std::uint64_t, Segmentation> results_;
  std::map<std::uint64_t, bool> finished_;  // id -> succeeded, for waitFor (bounded like results_)
  bool stop_ = false;
  Stats stats_;
  std::string last_error_;
  std::thread worker_;
};

}  // namespace rvwo
