#pragma once
/// @file
/// The Modbus TCP frame header (MBAP, Modbus Messaging on TCP/IP v1.0b,
/// section 3.1.3) and the PDU lengths each side must see. libmodbus frames
/// by function code and takes the header on trust (its protocol id check
/// lets 0x0001 through); both our client and rig-sim check it here, so a
/// frame from a confused or hostile peer is refused, not answered or used.
///
///   transaction id (2) | protocol id (2, always 0) | length (2: unit id +
///   PDU bytes) | unit id (1) | PDU (function code + data)

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

namespace piezo::hal::modbus {

inline constexpr std::size_t kMbapBytes = 7;      ///< header including the unit id
inline constexpr std::size_t kMaxTcpFrame = 260;  ///< the largest ADU Modbus TCP allows
inline constexpr int kMaxMbapLength = 254;        ///< unit id + the largest PDU (253)

struct Mbap {
  std::uint16_t transaction = 0;
  std::uint16_t protocol = 0;
  std::uint16_t length = 0;  ///< bytes after the length field: unit id + PDU
  std::uint8_t unit = 0;
};

[[nodiscard]] inline Mbap read_mbap(std::span<const std::uint8_t> bytes) {
  return {static_cast<std::uint16_t>(bytes[0] << 8 | bytes[1]),
          static_cast<std::uint16_t>(bytes[2] << 8 | bytes[3]),
          static_cast<std::uint16_t>(bytes[4] << 8 | bytes[5]), bytes[6]};
}

/// Where a server's receive buffer stands.
struct RequestFrame {
  enum class State { incomplete, complete, malformed } state = State::incomplete;
  std::size_t bytes = 0;  ///< the whole frame's length, when complete
  std::string_view why;   ///< when malformed
};

/// Looks at the start of a server's receive buffer: a whole request (its
/// header checked, and its length the one its function code implies), too
/// few bytes yet, or a frame no well-behaved client sends.
[[nodiscard]] RequestFrame next_request(std::span<const std::uint8_t> buffer);

}  // namespace piezo::hal::modbus
