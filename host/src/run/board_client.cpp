#include "board_client.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <zmq_addon.hpp>

#include "daemon/client_authentication.hpp"
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

std::string sensor_geometry_note(const config::ConfigFile& c, const protocol::Hello& hello) {
  const double board_r2 = hello.sensor.r2_m;
  if (board_r2 == c.board.axis().sensor.r2_m) return {};
  return fmt::format(
      "the board's sensor.r2_m is {:g} m, the host's config says {:g} m: angles use the "
      "board's (its sensor measured them)",
      board_r2, c.board.axis().sensor.r2_m);
}

}  // namespace piezo::host
