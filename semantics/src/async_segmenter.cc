// Copyright (c) 2026 the RVWO authors. BSD-3-Clause.
#include "rvwo/semantics/async_segmenter.h"

#include <algorithm>
#include <stdexcept>

namespace rvwo {

AsyncSegmenter::AsyncSegmenter(std::shared_ptr<Segmenter> segmenter, std::size_t queue_capacity,
                               std::size_t keep_results)
    : segmenter_(std::move(segmenter)), capacity_(queue_capacity), keep_(keep_results) {
  if (!segmenter_) throw std::invalid_argument("AsyncSegmenter: no segmenter");
  if (capacity_ == 0 || keep_ == 0) throw std::invalid_argument("AsyncSegmenter: capacities must be >= 1");
  worker_ = std::thread([this] { run(); });
}

AsyncSegmenter::~AsyncSegmenter() { shutdown(); }

void AsyncSegmenter::shutdown() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stop_ && !worker_.joinable()) return;
    stop_ = true;
    stats_.dropped += queue_.size();
    queue_.clear();
  }
  work_.notify_all();
  done_.notify_all();
  if (worker_.joinable() && worker_.get_id() != std::this_thread::get_id()) worker_.join();
}

bool AsyncSegmenter::submit(const cv::Mat& image, const FrameInfo& info) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stop_) return false;
    ++stats_.submitted;
    if (queue_.size() >= capacity_) {  // latest wins: the oldest waiting frame gives way
      finished_[queue_.front().info.id] = false;
      queue_.pop_front();
      ++stats_.dropped;
    }
    queue_.push_back({image, info});
  }
  work_.notify_one();
  return true;
}

void AsyncSegmenter::run() {
  for (;;) {
    Request r;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      work_.wait(lock, [this] { return stop_ || !queue_.empty(); });
      if (stop_) return;
      r = std::move(queue_.front());
      queue_.pop_front();
      running_ = r.info.id;
    }
    std::optional<Segmentation> result;
    std::string error;
    try {
      result = segmenter_->segment(r.image, r.info);
    } catch (const std::exception& e) {
      error = e.what();
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (result) {
        results_[r.info.id] = std::move(*result);
        ++stats_.processed;
        while (results_.size() > keep_) results_.erase(results_.begin());
      } else {
        ++stats_.failed;
        last_error_ = error;
      }
      finished_[r.info.id] = result.has_value();
      running_.reset();
      while (finished_.size() > 4 * keep_) finished_.erase(finished_.begin());
    }
    done_.notify_all();
  }
}

std::optional<Segmentation> AsyncSegmenter::take(std::uint64_t id) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = results_.find(id);
  if (it == results_.end()) return std::nullopt;
  Segmentation s = std::move(it->second);
  results_.erase(it);
  return s;
}

std::optional<Segmentation> AsyncSegmenter::waitFor(std::uint64_t id, std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  done_.wait_for(lock, timeout, [&] { return stop_ || finished_.count(id) > 0; });
  auto it = results_.find(id);
  if (it == results_.end()) return std::nullopt;
  Segmentation s = std::move(it->second);
  results_.erase(it);
  return s;
}

bool AsyncSegmenter::pending(std::uint64_t id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (stop_) return false;
  if (running_ == id || results_.count(id)) return true;
  return std::any_of(queue_.begin(), queue_.end(), [&](const Request& r) { return r.info.id == id; });
}

AsyncSegmenter::Stats AsyncSegmenter::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

std::string AsyncSegmenter::lastError() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_error_;
}

}  // namespace rvwo
