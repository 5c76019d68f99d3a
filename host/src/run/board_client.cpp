#include "board_client.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <random>
#include <zmq_addon.hpp>

#include "daemon/client_authentication.hpp"
#include "piezo/config/config_error.hpp"
#include "piezo/firmware/wire_keys.hpp"
#include "piezo/protocol/board_identity.hpp"
#include "piezo/protocol/endpoints.hpp"
#include "piezo/protocol/message.hpp"

namespace piezo::host {

BoardClient::BoardClient(const config::BoardAddress& rig)
    : BoardClient(rig, std::make_shared<zmq::context_t>()) {}

BoardClient::BoardClient(const config::BoardAddress& rig, zmq::context_t& shared)
    : BoardClient(rig, std::shared_ptr<zmq::context_t>(&shared, [](zmq::context_t*) {})) {}

BoardClient::BoardClient(const config::BoardAddress& rig, std::shared_ptr<zmq::context_t> context)
    : address_(rig.address), context_(std::move(context)) {
  if (!rig.server_public_key_file.empty() || !rig.client_secret_key_file.empty()) {
    if (rig.server_public_key_file.empty() || rig.client_secret_key_file.empty()) {
      throw std::runtime_error(
          "rig: CURVE needs both server_public_key_file and "
          "client_secret_key_file");
    }
    curve_ = Curve{daemon::read_key(rig.server_public_key_file, "public-key"),
                   daemon::read_key(rig.client_secret_key_file, "public-key"),
                   daemon::read_key(rig.client_secret_key_file, "secret-key")};
  }
  // A routing id of the client's own (ZeroMQ reserves a leading zero byte
  // for the ids it makes up), random so that no other client guesses it.
  std::random_device entropy;
  routing_id_ = fmt::format("piezo-{:08x}{:08x}", entropy(), entropy());
  stream_ = open_socket(zmq::socket_type::sub);
  stream_.set(zmq::sockopt::rcvhwm, 100'000);
  try {
    stream_.connect(protocol::loopback_literal(protocol::stream_endpoint(address_)));
  } catch (const zmq::error_t& e) {
    throw std::runtime_error(fmt::format("rig address \"{}\": {}", address_, e.what()));
  }
  open_commands();
}

zmq::socket_t BoardClient::open_socket(zmq::socket_type type) const {
  zmq::socket_t s(*context_, type);
  if (curve_) {
    s.set(zmq::sockopt::curve_serverkey, curve_->server_public);
    s.set(zmq::sockopt::curve_publickey, curve_->public_key);
    s.set(zmq::sockopt::curve_secretkey, curve_->secret_key);
  }
  s.set(zmq::sockopt::linger, 0);  // closing drops what was not sent
  s.set(zmq::sockopt::reconnect_ivl, 100);
  s.set(zmq::sockopt::reconnect_ivl_max, 2000);  // back-off after an outage
  if (protocol::is_ipv6_endpoint(address_)) s.set(zmq::sockopt::ipv6, 1);
  return s;
}

void BoardClient::open_commands() {
  commands_ = open_socket(zmq::socket_type::dealer);
  commands_.set(zmq::sockopt::routing_id, routing_id_);
  try {
    commands_.connect(protocol::loopback_literal(address_));
  } catch (const zmq::error_t& e) {
    throw std::runtime_error(fmt::format("rig address \"{}\": {}", address_, e.what()));
  }
}

bool poll_in(zmq::socket_t& socket, std::chrono::milliseconds timeout) {
  zmq::pollitem_t item{socket.handle(), 0, ZMQ_POLLIN, 0};
  try {
    zmq::poll(&item, 1, timeout);
  } catch (const zmq::error_t& e) {
    if (e.num() == EINTR) return false;
    throw;
  }
  return (item.revents & ZMQ_POLLIN) != 0;
}

void BoardClient::send(const std::string& cmd, const nlohmann::json& args) {
  nlohmann::json named = args;
  if (!board_id_.empty() && protocol::names_board(cmd)) named[wire_key::board] = board_id_;
  const std::string body = protocol::encode_request({next_id_++, cmd, named});
  (void)commands_.send(zmq::buffer(body), zmq::send_flags::dontwait);
}

nlohmann::json BoardClient::call(const std::string& cmd, const nlohmann::json& args,
                                 std::chrono::milliseconds timeout) {
  const std::uint64_t id = next_id_;
  send(cmd, args);
  const auto give_up = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        give_up - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      open_commands();  // the request, if still queued here, goes with the old socket
      throw LinkTimeout(fmt::format("{}: no reply from piezod at {} within {} ms", cmd, address_,
                                    timeout.count()));
    }
    if (!poll_in(commands_, left)) continue;
    zmq::message_t message;
    if (!commands_.recv(message, zmq::recv_flags::dontwait)) continue;
    const auto reply = protocol::decode_reply(message.to_string_view());
    if (reply.id != id) continue;  // a late reply to an earlier command
    if (!reply.ok) throw RemoteError(reply.error.code, reply.error.key, reply.error.message);
    return reply.result;
  }
}

void BoardClient::subscribe(std::initializer_list<std::string_view> topics) {
  for (const std::string_view t : topics) stream_.set(zmq::sockopt::subscribe, t);
}

protocol::Hello BoardClient::hello() {
  const nlohmann::json hello = call("hello");
  // The version first: another version's hello may hold other fields.
  const auto version = hello.value(wire_key::protocol, std::uint64_t{0});
  if (version != protocol::kProtocolVersion) {
    throw std::runtime_error(fmt::format(
        "piezod at {} speaks protocol version {}, this piezo version {}: update one of them",
        address_, version, protocol::kProtocolVersion));
  }
  auto typed = protocol::decode<protocol::Hello>(hello);
  board_id_ = typed.board_id;
  return typed;
}

const protocol::AxisInfo& axis_info(const protocol::Hello& hello, const std::string& axis,
                                    const std::string& board_address) {
  std::string names;
  for (const auto& a : hello.axes) names += (names.empty() ? "" : ", ") + a.name;
  // A board of one takes its axis unnamed (docs/protocol.md, "Axes").
  if (axis.empty() && hello.axes.size() == 1) return hello.axes.front();
  if (axis.empty()) {
    throw config::ConfigError("piezod at " + board_address, "rig.axis",
                              fmt::format("required: the board has several axes ({}); name "
                                          "one with --axis or [rig] axis",
                                          names));
  }
  for (const protocol::AxisInfo& a : hello.axes)
    if (a.name == axis) return a;
  throw config::ConfigError(
      "piezod at " + board_address, "rig.axis",
      fmt::format("\"{}\" is not an axis of the board (allowed: {})", axis, names));
}

std::string sensor_geometry_note(const config::ConfigFile& c, const protocol::AxisInfo& axis) {
  // The config's axis of the same name (a config of one axis: its own).
  const config::AxisConfig* own = c.board.find_axis(axis.name);
  const double config_r2 = (own != nullptr ? *own : c.board.axis()).sensor.r2_m;
  const double board_r2 = axis.r2_m;
  if (board_r2 == config_r2) return {};
  return fmt::format(
      "the board's sensor.r2_m is {:g} m, the host's config says {:g} m: angles use the "
      "board's (its sensor measured them)",
      board_r2, config_r2);
}

}  // namespace piezo::host
