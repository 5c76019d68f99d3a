#pragma once
// A client of piezod (docs/protocol.md): a DEALER for commands, each
// matched to its reply by id, and a SUB on the sample stream next to it.

#include <chrono>
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <zmq.hpp>

#include "config/config_file.hpp"
#include "link_timeout.hpp"
#include "piezo/protocol/error.hpp"
#include "piezo/protocol/messages.hpp"

namespace piezo::host {

/// An error reply: the daemon refused the command ({code, key, message}).
class RemoteError : public protocol::ProtocolError {
 public:
  using ProtocolError::ProtocolError;
};

/// zmq::poll on one socket; false on timeout or when a signal interrupts it
/// (the caller looks at its stop flag and polls again).
bool poll_in(zmq::socket_t& socket, std::chrono::milliseconds timeout);

class BoardClient {
 public:
  /// Connects both sockets (ZeroMQ reconnects by itself after an outage);
  /// with CURVE key files in `rig`, as an authorized client.
  explicit BoardClient(const config::BoardAddress& rig);
  /// On a context shared with an in-process piezod (inproc:// addresses).
  BoardClient(const config::BoardAddress& rig, zmq::context_t& shared);

  /// Sends a command and waits for its reply; replies to earlier commands
  /// that arrive meanwhile are dropped. Throws RemoteError or LinkTimeout.
  /// A request given up on never reaches the board later: at the timeout
  /// the command socket, with what it still holds, is closed and another
  /// opened under the same routing id (the board hands the connection over,
  /// so a controller stays one). Once `hello` has named the board start,
  /// every request that may name it does (docs/protocol.md, "A board's
  /// identity"): a board that restarted since refuses it (`stale_board`).
  nlohmann::json call(const std::string& cmd, const nlohmann::json& args = nlohmann::json::object(),
                      std::chrono::milliseconds timeout = std::chrono::milliseconds(2000));
  /// The board's `hello`, typed. Throws (naming the board's address and
  /// both versions) when the board speaks another protocol version than
  /// this host, and ProtocolError when its hello lacks what the protocol
  /// says it holds.
  [[nodiscard]] protocol::Hello hello();
  /// Sends a command without waiting (lease renewals); its reply is dropped.
  void send(const std::string& cmd, const nlohmann::json& args = nlohmann::json::object());

  /// The board start `hello` named (empty before it).
  [[nodiscard]] const std::string& board_id() const { return board_id_; }
  /// Subscribes the stream to the given topics ("drive", "sensor", "state", "health").
  void subscribe(std::initializer_list<std::string_view> topics);
  [[nodiscard]] zmq::socket_t& stream() { return stream_; }
  [[nodiscard]] const std::string& address() const { return address_; }

 private:
  BoardClient(const config::BoardAddress& rig, std::shared_ptr<zmq::context_t> context);
  /// A socket of `type` with this client's keys and reconnection options.
  [[nodiscard]] zmq::socket_t open_socket(zmq::socket_type type) const;
  /// A new command socket under this client's routing id, connected.
  void open_commands();

  struct Curve {
    std::string server_public, public_key, secret_key;
  };
  std::string address_;
  std::optional<Curve> curve_;
  std::string routing_id_;  ///< this client's, kept across reopened command sockets
  std::string board_id_;    ///< the board start hello named
  std::shared_ptr<zmq::context_t> context_;  ///< its own, or a shared one (not owned)
  zmq::socket_t commands_, stream_;
  std::uint64_t next_id_ = 1;
};

/// The board's axis `axis` names ([rig] axis, --axis; empty: the board's
/// one axis), resolved once. Throws ConfigError (key `rig.axis`, listing the
/// board's axes) for an axis the board lacks, or none on a board of several.
[[nodiscard]] const protocol::AxisInfo& axis_info(const protocol::Hello& hello,
                                                  const std::string& axis,
                                                  const std::string& board_address);

/// The board's sensor measured the samples, so its radius (the axis's
/// `r2_m` in hello) turns them into angles, whatever the host's config says:
/// a note when the host's config says another radius (empty when they agree).
[[nodiscard]] std::string sensor_geometry_note(const config::ConfigFile& c,
                                               const protocol::AxisInfo& axis);

}  // namespace piezo::host
