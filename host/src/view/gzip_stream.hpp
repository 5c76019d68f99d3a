#pragma once
// A gzip stream written a piece at a time, for the live event stream: each
// piece is flushed whole (Z_SYNC_FLUSH), so a browser decodes an event as
// it arrives, and the compressor's window carries across pieces, so what
// events repeat (keys, the status, digits of nearby numbers) costs little.
// The live page's JSON shrinks about fourfold (docs/live-view.md).

#include <zlib.h>

#include <string>
#include <string_view>

namespace piezo::host::view {

class GzipStream {
 public:
  GzipStream();
  ~GzipStream();
  GzipStream(const GzipStream&) = delete;
  GzipStream& operator=(const GzipStream&) = delete;

  /// The next piece of the stream, compressed and flushed; the first
  /// carries the gzip header.
  [[nodiscard]] std::string compress(std::string_view piece);

 private:
  z_stream z_{};
};

/// Whether an Accept-Encoding header allows gzip (and does not refuse it
/// with q=0).
[[nodiscard]] bool accepts_gzip(std::string_view accept_encoding);

}  // namespace piezo::host::view
