#pragma once
/// @file
/// A refused request: the error reply's {code, key, message}.

#include <array>
#include <stdexcept>
#include <string>
#include <string_view>

namespace piezo::protocol {

/// Error codes (docs/protocol.md, "Errors").
namespace code {
inline constexpr const char* malformed = "malformed";  ///< not a request at all
inline constexpr const char* too_large = "too_large";  ///< over kMaxMessageBytes
inline constexpr const char* unknown_command = "unknown_command";
inline constexpr const char* bad_argument = "bad_argument";    ///< wrong type or missing
inline constexpr const char* out_of_limits = "out_of_limits";  ///< beyond the board's limits
inline constexpr const char* bad_state = "bad_state";  ///< not now (e.g. start while running)
inline constexpr const char* fault_latched = "fault_latched";  ///< reset_fault first
inline constexpr const char* not_controller =
    "not_controller";                                          ///< another client controls the rig
inline constexpr const char* rate_limited = "rate_limited";    ///< over a client's fetch budget
inline constexpr const char* not_available = "not_available";  ///< samples no longer recorded
inline constexpr const char* bad_frame = "bad_frame";  ///< a sample frame that does not decode
inline constexpr const char* internal = "internal";    ///< the daemon failed; it goes on
/// A request naming another board start than this one: sent to a board
/// that has restarted since its client last asked `hello`.
inline constexpr const char* stale_board = "stale_board";
/// Every code, in the docs' order (the board's dictionary lists them).
inline constexpr std::array<const char*, 13> kAll{
    malformed,      too_large,    unknown_command, bad_argument, out_of_limits,
    bad_state,      fault_latched, not_controller, rate_limited, not_available,
    bad_frame,      internal,     stale_board};
}  // namespace code

class ProtocolError : public std::runtime_error {
 public:
  ProtocolError(std::string code, std::string_view key, const std::string& message)
      : std::runtime_error(message), code_(std::move(code)), key_(key) {}
  [[nodiscard]] const std::string& code() const { return code_; }
  [[nodiscard]] const std::string& key() const { return key_; }

 private:
  std::string code_, key_;
};

}  // namespace piezo::protocol
