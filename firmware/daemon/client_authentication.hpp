#pragma once
// Who may talk to piezod on a network address (ZeroMQ CURVE): key pairs (`piezod
// keygen`), key files, and the ZAP handler that admits only the clients
// whose public keys are in the authorized-keys file and logs every refusal.

#include <ostream>
#include <string>
#include <vector>
#include <zmq.hpp>

namespace piezo::daemon {

struct KeyPair {
  std::string public_key, secret_key;  ///< Z85, 40 characters each
};

[[nodiscard]] KeyPair generate_keypair();
/// Writes DIR/NAME.key (both keys, mode 0600) and DIR/NAME.pub (public).
void write_keypair(const KeyPair& keys, const std::string& dir, const std::string& name,
                   bool force = false);
/// Reads a key file written by write_keypair: the "secret-key" or
/// "public-key" entry. Throws naming the file and the entry.
[[nodiscard]] std::string read_key(const std::string& path, const std::string& entry);
/// One Z85 public key per line; '#' starts a comment. Throws naming the
/// file and line of a key that is not 40 Z85 characters.
[[nodiscard]] std::vector<std::string> read_authorized_keys(const std::string& path);

/// Answers ZAP requests (RFC 27) on inproc://zeromq.zap.01 for this context.
class ZapHandler {
 public:
  ZapHandler(zmq::context_t& context, std::vector<std::string> authorized, std::ostream& log);
  [[nodiscard]] zmq::socket_t& socket() { return socket_; }
  /// Handles one request waiting on the socket.
  void handle();

 private:
  zmq::socket_t socket_;
  std::vector<std::string> authorized_;
  std::ostream& log_;
};

}  // namespace piezo::daemon
