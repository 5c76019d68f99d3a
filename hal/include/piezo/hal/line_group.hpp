#pragma once
/// @file
/// Raw digital lines at their physical levels (1 = high voltage): the
/// narrow boundary below the parallel-DAC and digital-line logic. libgpiod
/// implements it on the rig; the simulation records it for tests.

#include <cstddef>
#include <cstdint>
#include <span>

#include "piezo/hal/status.hpp"

namespace piezo::hal {

/// Output lines set together, in a fixed order, by one call.
class OutputLineGroup {
 public:
  OutputLineGroup() = default;
  OutputLineGroup(const OutputLineGroup&) = delete;
  OutputLineGroup& operator=(const OutputLineGroup&) = delete;
  virtual ~OutputLineGroup() = default;

  /// Sets every line of the group at once (levels.size() == size()). Real-time safe.
  virtual Status set_levels(std::span<const int> levels) = 0;
  [[nodiscard]] virtual std::size_t size() const = 0;
};

/// One input line with edge detection.
class InputLine {
 public:
  InputLine() = default;
  InputLine(const InputLine&) = delete;
  InputLine& operator=(const InputLine&) = delete;
  virtual ~InputLine() = default;

  /// The physical level now. Real-time safe.
  virtual Status level(int& level) = 0;
  /// Edges (either direction) since the last call, without blocking. Real-time safe.
  virtual Status take_edges(int& count) = 0;
  /// Blocks until an edge is pending (`ready` true) or `timeout_ns` passes.
  /// For a line's own watcher thread, never for the real-time loop.
  virtual Status wait_for_edge(std::int64_t timeout_ns, bool& ready) = 0;
  /// When the latest edge taken happened, on CLOCK_MONOTONIC [ns]; 0 if none.
  [[nodiscard]] virtual std::int64_t last_edge_ns() const { return 0; }
};

}  // namespace piezo::hal
