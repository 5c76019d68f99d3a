#pragma once
// The board's data recorder: every sample of the current (or last) run,
// numbered from 0, kept in a ring sized in seconds at the configured rate,
// so a client that lost the link fetches what it missed. Used by the
// daemon's network thread only; allocated once.

#include <algorithm>
#include <cstdint>
#include <vector>

namespace piezo::daemon {

template <typename Sample>
class Recorder {
 public:
  using value_type = Sample;

  explicit Recorder(std::size_t capacity) : ring_(std::max<std::size_t>(capacity, 1)) {}

  /// A new run: numbering restarts at 0.
  void clear() { next_ = 0; }
  void push(const Sample& s) { ring_[next_++ % ring_.size()] = s; }

  /// The next sequence number to be recorded (= samples so far).
  [[nodiscard]] std::uint64_t next() const { return next_; }
  /// The oldest sequence number still held.
  [[nodiscard]] std::uint64_t first() const {
    return next_ > ring_.size() ? next_ - ring_.size() : 0;
  }
  [[nodiscard]] std::size_t capacity() const { return ring_.size(); }

  /// Samples [first, first + count) clipped to what was recorded; the
  /// caller checks first() beforehand.
  void copy(std::uint64_t from, std::uint64_t count, std::vector<Sample>& out) const {
    out.clear();
    const std::uint64_t end = std::min(next_, from + count);
    for (std::uint64_t seq = std::max(from, first()); seq < end; ++seq) {
      out.push_back(ring_[seq % ring_.size()]);
    }
  }

 private:
  std::vector<Sample> ring_;
  std::uint64_t next_ = 0;
};

}  // namespace piezo::daemon
