#pragma once
/// @file
/// Simulated raw lines: an output group that records every bulk write (for
/// checking codes, bit order, strobe sequences and polarity) and an input
/// whose level a test or simulation sets.

#include <atomic>
#include <vector>

#include "piezo/hal/clock.hpp"
#include "piezo/hal/line_group.hpp"

namespace piezo::hal::sim {

class RecordingOutputLines final : public OutputLineGroup {
 public:
  /// With a clock, each write is also time-stamped.
  explicit RecordingOutputLines(std::size_t lines, const Clock* clock = nullptr)
      : lines_(lines), clock_(clock) {}

  /// Records the write. Allocates: a test device, not for real-time runs.
  Status set_levels(std::span<const int> levels) override {
    if (levels.size() != lines_) return Status::io_error;
    writes_.emplace_back(levels.begin(), levels.end());
    times_.push_back(clock_ != nullptr ? clock_->now() : 0);
    return Status::ok;
  }
  [[nodiscard]] std::size_t size() const override { return lines_; }

  /// Every bulk write so far, in order.
  [[nodiscard]] const std::vector<std::vector<int>>& writes() const { return writes_; }
  [[nodiscard]] const std::vector<TimeNs>& times() const { return times_; }
  void clear() {
    writes_.clear();
    times_.clear();
  }

 private:
  std::size_t lines_;
  const Clock* clock_;
  std::vector<std::vector<int>> writes_;
  std::vector<TimeNs> times_;
};

class SimInputLine final : public InputLine {
 public:
  explicit SimInputLine(int level) : level_(level) {}

  /// Drives the line (any thread); a change counts as an edge.
  void drive(int level) {
    if (level_.exchange(level) != level) edges_.fetch_add(1);
  }
  Status level(int& level) override {
    level = level_.load();
    return Status::ok;
  }
  Status take_edges(int& count) override {
    count = edges_.exchange(0);
    return Status::ok;
  }

 private:
  std::atomic<int> level_;
  std::atomic<int> edges_{0};
};

}  // namespace piezo::hal::sim
