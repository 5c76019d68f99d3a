#pragma once
/// @file
/// The result of a real-time HAL call: a small value, never an exception.
/// The text of a failure travels to the non-real-time side as this code.

#include <cstdint>
#include <string_view>

namespace piezo::hal {

enum class [[nodiscard]] Status : std::uint8_t{
    ok = 0,
    timeout,          ///< the device did not answer in time
    invalid_reading,  ///< the device answered but flags its value invalid (e.g. no target)
    crc_error,        ///< a corrupted frame
    exception_reply,  ///< a protocol-level refusal (e.g. a Modbus exception code)
    disconnected,     ///< the link is down
    io_error,         ///< any other error of the underlying call
    out_of_range,     ///< a request outside the device's limits was refused, or a
                      ///< reading outside the sensor's measuring range
    bad_reply,        ///< a reply whose header does not fit its request (Modbus TCP's MBAP)
};

/// The highest code: codes above it are not a Status.
inline constexpr Status kLastStatus = Status::bad_reply;

[[nodiscard]] constexpr std::string_view to_string(Status s) {
  switch (s) {
    case Status::ok:
      return "ok";
    case Status::timeout:
      return "timeout";
    case Status::invalid_reading:
      return "invalid_reading";
    case Status::crc_error:
      return "crc_error";
    case Status::exception_reply:
      return "exception_reply";
    case Status::disconnected:
      return "disconnected";
    case Status::io_error:
      return "io_error";
    case Status::out_of_range:
      return "out_of_range";
    case Status::bad_reply:
      return "bad_reply";
  }
  return "unknown";
}

}  // namespace piezo::hal
