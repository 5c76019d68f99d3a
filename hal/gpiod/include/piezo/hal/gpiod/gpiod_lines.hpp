#pragma once
/// @file
/// The thin libgpiod 1.6 adapter: line groups on a GPIO chip at their
/// physical levels. Polarity, bit order and sequencing live above it
/// (hal/gpio). Request errors throw (set-up); register-time calls return a
/// Status.

#include <gpiod.h>

#include <string>
#include <vector>

#include "piezo/hal/line_group.hpp"

namespace piezo::hal::gpiod {

/// Outputs requested together: one ioctl sets them all.
class GpiodOutputs final : public OutputLineGroup {
 public:
  /// Requests `offsets` of `chip` (a name like "gpiochip0" or a path) as
  /// outputs that start at `initial_levels` (physical, one per offset): the
  /// kernel drives them so from the request on, before any write.
  GpiodOutputs(const std::string& chip, const std::vector<unsigned>& offsets,
               const std::vector<int>& initial_levels, const std::string& consumer);
  ~GpiodOutputs() override;

  Status set_levels(std::span<const int> levels) override;
  [[nodiscard]] std::size_t size() const override { return size_; }

 private:
  gpiod_chip* chip_ = nullptr;
  gpiod_line_bulk bulk_{};
  std::size_t size_ = 0;
};

/// An input requested for events on both edges.
class GpiodEdgeInput final : public InputLine {
 public:
  GpiodEdgeInput(const std::string& chip, unsigned offset, const std::string& consumer);
  ~GpiodEdgeInput() override;

  Status level(int& level) override;
  Status take_edges(int& count) override;
  Status wait_for_edge(std::int64_t timeout_ns, bool& ready) override;
  /// The kernel's time stamp of the latest edge (CLOCK_MONOTONIC).
  [[nodiscard]] std::int64_t last_edge_ns() const override { return last_edge_ns_; }

 private:
  gpiod_chip* chip_ = nullptr;
  gpiod_line* line_ = nullptr;
  std::int64_t last_edge_ns_ = 0;
};

}  // namespace piezo::hal::gpiod
