#pragma once
// The recorder's spill file: every sample frame of the current run,
// appended as [u32 little-endian length][frame], so a client can fetch
// samples the memory ring no longer holds. Written and read by the
// daemon's network thread only.

#include <cstdint>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>

#include "piezo/protocol/frame.hpp"

namespace piezo::daemon {

class SpillFile {
 public:
  /// Opens (truncates) the file; throws naming it when it cannot. A
  /// non-empty file (a crashed daemon's run) is first kept as PATH.previous.
  explicit SpillFile(std::string path);
  /// A new run: starts the file again.
  void clear();
  void append(std::string_view frame);
  /// Samples [first, first + count) of `stream` as one frame, from the
  /// file; nullopt when the file does not hold `first`.
  [[nodiscard]] std::optional<std::string> fetch(protocol::Stream stream, std::uint64_t first,
                                                 std::uint64_t count);

 private:
  std::string path_;
  std::fstream file_;
};

}  // namespace piezo::daemon
