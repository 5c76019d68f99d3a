#include "board_client.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <zmq_addon.hpp>

#include "daemon/client_authentication.hpp"
#include "piezo/config/config_error.hpp"
#include "piezo/firmware/wire_keys.hpp"
#include "piezo/protocol/endpoints.hpp"
#include "piezo/protocol/message.hpp"

namespace piezo::host {

BoardClient::BoardClient(const config::BoardAddress& rig)
    : BoardClient(rig, std::make_shared<zmq::context_t>()) {}

BoardClient::BoardClient(const config::BoardAddress& rig, zmq::context_t& shared)
    : BoardClient(rig, std::shared_ptr<zmq::context_t>(&shared, [](zmq::context_t*) {})) {}

BoardClient::BoardClient(const config::BoardAddress& rig, std::shared_ptr<zmq::context_t> context)
    : address_(rig.address),
      context_(std::move(context)),
      commands_(*context_, zmq::socket_type::dealer),
      stream_(*context_, zmq::socket_type::sub) {
  const std::string stream_address = protocol::stream_endpoint(address_);
  if (!rig.server_public_key_file.empty() || !rig.client_secret_key_file.empty()) {
    if (rig.server_public_key_file.empty() || rig.client_secret_key_file.empty()) {
      throw std::runtime_error(
          "rig: CURVE needs both server_public_key_file and "
          "client_secret_key_file");
    }
    const std::string server = daemon::read_key(rig.server_public_key_file, "public-key");
    const std::string mine = daemon::read_key(rig.client_secret_key_file, "public-key");
    const std::string secret = daemon::read_key(rig.client_secret_key_file, "secret-key");
    for (auto* s : {&commands_, &stream_}) {
      s->set(zmq::sockopt::curve_serverkey, server);
      s->set(zmq::sockopt::curve_publickey, mine);
      s->set(zmq::sockopt::curve_secretkey, secret);
    }
  }
  for (auto* s : {&commands_, &stream_}) {
    s->set(zmq::sockopt::linger, 0);
    s->set(zmq::sockopt::reconnect_ivl, 100);
    s->set(zmq::sockopt::reconnect_ivl_max, 2000);  // back-off after an outage
  }
  stream_.set(zmq::sockopt::rcvhwm, 100'000);
  if (protocol::is_ipv6_endpoint(address_)) {
    commands_.set(zmq::sockopt::ipv6, 1);
    stream_.set(zmq::sockopt::ipv6, 1);
  }
  try {
    commands_.connect(protocol::loopback_literal(address_));
    stream_.connect(protocol::loopback_literal(stream_address));
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
  const std::string body = protocol::encode_request({next_id_++, cmd, args});
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

void BoardClient::subscribe(std::initializer_list<const char*> topics) {
  for (const char* t : topics) stream_.set(zmq::sockopt::subscribe, t);
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
  return protocol::decode<protocol::Hello>(hello);
}

protocol::Hello axis_view(const protocol::Hello& hello, const std::string& axis,
                          const std::string& board_address) {
  std::string names;
  for (const auto& a : hello.axes) names += (names.empty() ? "" : ", ") + a.name;
  if (axis.empty()) {
    if (hello.axes.size() <= 1) return hello;
    throw config::ConfigError("piezod at " + board_address, "rig.axis",
                              fmt::format("required: the board has several axes ({}); name "
                                          "one with --axis or [rig] axis",
                                          names));
  }
  for (const protocol::AxisInfo& a : hello.axes) {
    if (a.name != axis) continue;
    protocol::Hello view = hello;
    view.sensor = {a.r2_m, a.zero_displacement_m};
    view.limits.V_min = a.V_min;
    view.limits.V_max = a.V_max;
    view.limits.slew_V_per_s = a.slew_V_per_s;
    view.backends.drive = a.drive;
    view.backends.sensor = a.sensor;
    view.calibration = a.calibration;
    return view;
  }
  throw config::ConfigError("piezod at " + board_address, "rig.axis",
                            fmt::format("\"{}\" is not an axis of the board (allowed: {})", axis,
                                        names.empty() ? "none named: a board of one" : names));
}

std::string sensor_geometry_note(const config::ConfigFile& c, const protocol::Hello& hello) {
  // The config's axis of the same name (a config of one axis: its own).
  const config::AxisConfig* own = c.board.find_axis(c.host.board.axis);
  const double config_r2 = (own != nullptr ? *own : c.board.axis()).sensor.r2_m;
  const double board_r2 = hello.sensor.r2_m;
  if (board_r2 == config_r2) return {};
  return fmt::format(
      "the board's sensor.r2_m is {:g} m, the host's config says {:g} m: angles use the "
      "board's (its sensor measured them)",
      board_r2, config_r2);
}

}  // namespace piezo::host
