#pragma once
// Where piezod's two sockets are: commands at the address the client is
// given, the sample stream next to it (docs/protocol.md, "Transport").

#include <string>
#include <string_view>

namespace piezo::protocol {

/// tcp://HOST:PORT -> tcp://HOST:PORT+1; ipc://PATH and inproc://NAME get
/// "-stream" appended. Throws std::invalid_argument on anything else.
[[nodiscard]] std::string stream_endpoint(const std::string& command_endpoint);

/// True for addresses other peers can reach: TCP on anything but loopback.
[[nodiscard]] bool is_network_endpoint(const std::string& endpoint);

/// True for tcp://[IPv6]:PORT: its sockets need ZeroMQ's IPv6 option.
[[nodiscard]] bool is_ipv6_endpoint(const std::string& endpoint);

/// `endpoint` with tcp://localhost:PORT as tcp://127.0.0.1:PORT, for binding
/// and connecting alike: ZeroMQ binds addresses and interface names only,
/// and a resolver may know no localhost (a minimal root has no /etc/hosts).
[[nodiscard]] std::string loopback_literal(const std::string& endpoint);

}  // namespace piezo::protocol
