#include "gzip_stream.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <stdexcept>

namespace piezo::host::view {
namespace {

/// 15-bit window, +16: a gzip wrapper (what Content-Encoding: gzip means).
constexpr int kGzipWindowBits = 15 + 16;
/// Level 6 (zlib's default) costs about 2 ms of a worker per 100 kB of
/// events here; lower levels save little time and lose a fifth of the gain.
constexpr int kLevel = 6;
constexpr int kMemLevel = 8;

}  // namespace

GzipStream::GzipStream() {
  if (deflateInit2(&z_, kLevel, Z_DEFLATED, kGzipWindowBits, kMemLevel, Z_DEFAULT_STRATEGY) !=
      Z_OK) {
    throw std::runtime_error("zlib: cannot start a gzip stream");
  }
}

GzipStream::~GzipStream() {
  deflateEnd(&z_);
}

std::string GzipStream::compress(std::string_view piece) {
  std::string out;
  // zlib takes non-const input pointers; it does not write through them.
  z_.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(piece.data()));
  z_.avail_in = static_cast<uInt>(piece.size());
  do {
    const std::size_t used = out.size();
    const std::size_t room = deflateBound(&z_, z_.avail_in) + 64;
    out.resize(used + room);
    z_.next_out = reinterpret_cast<Bytef*>(out.data() + used);
    z_.avail_out = static_cast<uInt>(room);
    if (deflate(&z_, Z_SYNC_FLUSH) == Z_STREAM_ERROR) {
      throw std::runtime_error("zlib: the gzip stream failed");
    }
    out.resize(used + room - z_.avail_out);
  } while (z_.avail_out == 0);
  return out;
}

bool accepts_gzip(std::string_view accept_encoding) {
  std::size_t start = 0;
  while (start <= accept_encoding.size()) {
    const std::size_t end = std::min(accept_encoding.find(',', start), accept_encoding.size());
    std::string item;
    for (char c : accept_encoding.substr(start, end - start)) {
      if (c != ' ' && c != '\t')
        item += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    }
    const std::size_t semicolon = item.find(';');
    const std::string coding = item.substr(0, semicolon);
    const std::size_t q = item.find(";q=");
    const bool refused =
        q != std::string::npos && std::strtod(item.c_str() + q + 3, nullptr) <= 0.0;
    if ((coding == "gzip" || coding == "x-gzip") && !refused) return true;
    start = end + 1;
  }
  return false;
}

}  // namespace piezo::host::view
