// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
//
// The front end: what tracking needs of a frame's images, made without the map (features, their
// stereo matches or depth, the image the segmenter will see), and the worker thread that makes it
// one frame ahead of tracking. Private to the library.
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <thread>

#include "context.h"

namespace rvwo::estimator {

struct FrameFeatures {
  Features f;
  cv::Mat raw_image;  // as the camera gave it, colour kept for a network (labels are rectified after)
};

class FrontEnd {
 public:
  explicit FrontEnd(Context& ctx);
  FrameFeatures operator()(const FrameInput& in) const;

 private:
  static cv::Mat toGrey(const cv::Mat& image);

  Context& ctx_;
  FeatureExtractor extractor_;
};

// One worker thread running tasks in the order given; submit() returns the result's future
// (an exception thrown by the task comes out of its get()).
class TaskQueue {
 public:
  TaskQueue() : thread_([this] { run(); }) {}
  ~TaskQueue() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_one();
    thread_.join();
  }
  template <typename T>
  std::future<T> submit(std::function<T()> f) {
    auto task = std::make_shared<std::packaged_task<T()>>(std::move(f));
    std::future<T> result = task->get_future();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      tasks_.emplace_back([task] { (*task)(); });
    }
    cv_.notify_one();
    return result;
  }

 private:
  void run() {
    for (;;) {
      std::function<void()> task;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        cv_.wait(lock, [this] { return stop_ || !tasks_.empty(); });
        if (tasks_.empty()) return;  // stop, and nothing left
        task = std::move(tasks_.front());
        tasks_.pop_front();
      }
      task();
    }
  }
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> tasks_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace rvwo::estimator
