#include "piezo/hal/modbus/mbap.hpp"

namespace piezo::hal::modbus {
namespace {

/// The MBAP length (unit id + PDU) a request of `function` must have, from
/// the bytes after its header so far; 0: not known yet (need more bytes);
/// -1: a function whose length the header alone must give (answered with
/// an illegal-function exception).
int request_length(std::uint8_t function, std::span<const std::uint8_t> after_header) {
  switch (function) {
    case 1: case 2: case 3: case 4: case 5: case 6:
      return 6;  // unit, function, address (2), count or value (2)
    case 15: case 16:  // ... + byte count (1) + the bytes
      return after_header.size() < 6 ? 0 : 7 + after_header[5];
    case 22:
      return 8;  // unit, function, address, AND mask, OR mask
    case 23:  // read address and count, write address and count, byte count
      return after_header.size() < 10 ? 0 : 11 + after_header[9];
    default:
      return -1;
  }
}

}  // namespace

RequestFrame next_request(std::span<const std::uint8_t> buffer) {
  using State = RequestFrame::State;
  if (buffer.size() < kMbapBytes) return {};
  const Mbap h = read_mbap(buffer);
  if (h.protocol != 0) return {State::malformed, 0, "protocol id is not 0 (not Modbus)"};
  if (h.length < 2 || h.length > kMaxMbapLength) {
    return {State::malformed, 0, "MBAP length outside 2..254"};
  }
  const std::size_t whole = 6 + std::size_t{h.length};
  if (buffer.size() < kMbapBytes + 1) return {};
  const int needed = request_length(buffer[kMbapBytes], buffer.subspan(kMbapBytes));
  if (needed == 0 && buffer.size() < whole) return {};
  if (needed > 0 && needed != h.length) {
    return {State::malformed, 0, "MBAP length does not fit the function's request"};
  }
  if (needed == 0) {
    // The declared frame is whole but too short to hold its byte count.
    return {State::malformed, 0, "MBAP length does not fit the function's request"};
  }
  if (buffer.size() < whole) return {};
  return {State::complete, whole, {}};
}

}  // namespace piezo::hal::modbus
