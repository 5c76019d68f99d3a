#pragma once
/// @file
/// Simulated raw lines: an output group that records every bulk write (for
/// checking codes, bit order, strobe sequences and polarity) and an input
/// whose level a test or simulation sets.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <vector>

#include "piezo/hal/clock.hpp"
#include "piezo/hal/line_group.hpp"

namespace piezo::hal::sim {

class RecordingOutputLines final : public OutputLineGroup {
 public:
  /// With a clock, each write is also time-stamped.
  explicit RecordingOutputLines(std::size_t lines, const Clock* clock = nullptr)
      : lines_(lines), clock_(clock) {}

  /// Records the write (from any thread, as a line's watcher may write
  /// too). Allocates and locks: a test device, not for real-time runs.
  Status set_levels(std::span<const int> levels) override {
    if (levels.size() != lines_) return Status::io_error;
    const std::lock_guard lock(mutex_);
    writes_.emplace_back(levels.begin(), levels.end());
    times_.push_back(clock_ != nullptr ? clock_->now() : 0);
    return Status::ok;
  }
  [[nodiscard]] std::size_t size() const override { return lines_; }

  /// Every bulk write so far, in order, and when each came: copies taken
  /// under the lock, as a line's watcher may still be writing.
  [[nodiscard]] std::vector<std::vector<int>> writes() const {
    const std::lock_guard lock(mutex_);
    return writes_;
  }
  [[nodiscard]] std::vector<TimeNs> times() const {
    const std::lock_guard lock(mutex_);
    return times_;
  }
  /// The physical level of `line` now (the last write), or -1 before any.
  [[nodiscard]] int level(std::size_t line) const {
    const std::lock_guard lock(mutex_);
    return writes_.empty() ? -1 : writes_.back()[line];
  }
  void clear() {
    const std::lock_guard lock(mutex_);
    writes_.clear();
    times_.clear();
  }

 private:
  std::size_t lines_;
  const Clock* clock_;
  mutable std::mutex mutex_;
  std::vector<std::vector<int>> writes_;
  std::vector<TimeNs> times_;
};

class SimInputLine final : public InputLine {
 public:
  explicit SimInputLine(int level) : level_(level) {}

  /// Drives the line (any thread); a change counts as an edge.
  void drive(int level) {
    if (level_.exchange(level) != level) {
      const std::lock_guard lock(mutex_);
      edges_.fetch_add(1);
      edge_ready_.notify_all();
    }
  }
  Status level(int& level) override {
    level = level_.load();
    return Status::ok;
  }
  Status take_edges(int& count) override {
    count = edges_.exchange(0);
    return Status::ok;
  }
  Status wait_for_edge(std::int64_t timeout_ns, bool& ready) override {
    std::unique_lock lock(mutex_);
    ready = edge_ready_.wait_for(lock, std::chrono::nanoseconds(timeout_ns),
                                 [&] { return edges_.load() > 0; });
    return Status::ok;
  }

 private:
  std::atomic<int> level_;
  std::atomic<int> edges_{0};
  std::mutex mutex_;  // for the watcher's wait only
  std::condition_variable edge_ready_;
};

}  // namespace piezo::hal::sim
