#pragma once
/// @file
/// The result of a real-time HAL call: a small value, never an exception.
/// The text of a failure travels to the non-real-time side as this code.

#include <cstdint>
#include <string_view>

#include "piezo/name_table.hpp"

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

inline constexpr auto kStatusNames = names<Status>({{Status::ok, "ok"},
                                                    {Status::timeout, "timeout"},
                                                    {Status::invalid_reading, "invalid_reading"},
                                                    {Status::crc_error, "crc_error"},
                                                    {Status::exception_reply, "exception_reply"},
                                                    {Status::disconnected, "disconnected"},
                                                    {Status::io_error, "io_error"},
                                                    {Status::out_of_range, "out_of_range"},
                                                    {Status::bad_reply, "bad_reply"}});

[[nodiscard]] constexpr std::string_view to_string(Status s) {
  return kStatusNames.name(s);
}

}  // namespace piezo::hal
