#pragma once
/// @file
/// Commands and replies on the wire (docs/protocol.md, "Messages"): one
/// MessagePack map per ZeroMQ frame.
///   request  {"id": uint, "cmd": str, "args": map}
///   reply    {"id": uint, "ok": true,  "result": map}
///   error    {"id": uint|nil, "ok": false, "error": {"code", "key", "message"}}

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "piezo/protocol/error.hpp"

namespace piezo::protocol {

inline constexpr std::uint32_t kProtocolVersion = 6;
/// Larger commands are refused unread (no command needs more); replies
/// and stream messages are not limited.
inline constexpr std::size_t kMaxMessageBytes = 64 * 1024;
/// Up to this a larger command is still received and answered `too_large`;
/// beyond it ZeroMQ drops the sender's connection (it reconnects by
/// itself; its requests in flight are lost), so no peer can make the
/// daemon buffer more.
inline constexpr std::size_t kMaxTransportBytes = 16u << 20;

struct Request {
  std::uint64_t id = 0;
  std::string cmd;
  nlohmann::json args = nlohmann::json::object();
};

struct ErrorBody {
  std::string code, key, message;
};

struct Reply {
  std::optional<std::uint64_t> id;
  bool ok = false;
  nlohmann::json result = nlohmann::json::object();
  ErrorBody error;
};

[[nodiscard]] std::string encode_request(const Request& request);
/// Throws ProtocolError; `id_out` receives the id whenever it could be read,
/// so the error reply can carry it.
[[nodiscard]] Request decode_request(std::string_view bytes, std::optional<std::uint64_t>& id_out);

[[nodiscard]] std::string encode_reply(std::uint64_t id, const nlohmann::json& result);
[[nodiscard]] std::string encode_error(std::optional<std::uint64_t> id, const ErrorBody& error);
/// Throws ProtocolError (malformed) when the bytes are not a reply.
[[nodiscard]] Reply decode_reply(std::string_view bytes);

/// A MessagePack map (state events, health); throws ProtocolError.
[[nodiscard]] std::string encode_map(const nlohmann::json& map);
[[nodiscard]] nlohmann::json decode_map(std::string_view bytes);

/// Argument readers: throw ProtocolError(bad_argument, key) on a wrong type.
[[nodiscard]] double number_arg(const nlohmann::json& args, std::string_view key,
                                std::optional<double> fallback = std::nullopt);
[[nodiscard]] std::uint64_t uint_arg(const nlohmann::json& args, std::string_view key,
                                     std::optional<std::uint64_t> fallback = std::nullopt);
[[nodiscard]] std::string string_arg(const nlohmann::json& args, std::string_view key,
                                     std::optional<std::string> fallback = std::nullopt);
[[nodiscard]] bool bool_arg(const nlohmann::json& args, std::string_view key,
                            std::optional<bool> fallback = std::nullopt);
/// Refuses (bad_argument, naming the key and what `cmd` takes) any argument
/// not in `known`: a misspelt optional argument is an error, never ignored.
void refuse_unknown_args(const nlohmann::json& args, const std::vector<std::string_view>& known,
                         std::string_view cmd);

}  // namespace piezo::protocol
