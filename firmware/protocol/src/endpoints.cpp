#include "piezo/protocol/endpoints.hpp"

#include <stdexcept>

namespace piezo::protocol {

std::string stream_endpoint(const std::string& e) {
  if (e.starts_with("ipc://") || e.starts_with("inproc://")) return e + "-stream";
  if (e.starts_with("tcp://")) {
    const auto colon = e.rfind(':');
    if (colon != std::string::npos && colon > 5) {
      try {
        std::size_t used = 0;
        const int port = std::stoi(e.substr(colon + 1), &used);
        if (used == e.size() - colon - 1 && port > 0 && port < 65535) {
          return e.substr(0, colon + 1) + std::to_string(port + 1);
        }
      } catch (const std::exception&) {
      }
    }
  }
  throw std::invalid_argument(
      "\"" + e +
      "\" is not an address piezod serves (allowed: tcp://HOST:PORT with PORT 1..65534, "
      "ipc://PATH, inproc://NAME)");
}

bool is_ipv6_endpoint(const std::string& e) {
  return e.starts_with("tcp://[");
}

std::string loopback_literal(const std::string& e) {
  // ZeroMQ binds to an address or an interface name, not a host name; and
  // piezod's localhost is 127.0.0.1 whatever the resolver says.
  constexpr std::string_view kLocalhost = "tcp://localhost:";
  if (e.starts_with(kLocalhost)) return "tcp://127.0.0.1:" + e.substr(kLocalhost.size());
  return e;
}

bool is_network_endpoint(const std::string& e) {
  if (!e.starts_with("tcp://")) return false;
  const std::string host = e.substr(6, e.rfind(':') - 6);
  return host != "127.0.0.1" && host != "localhost" && host != "[::1]";
}

}  // namespace piezo::protocol
