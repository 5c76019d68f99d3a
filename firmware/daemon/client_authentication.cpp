#include "client_authentication.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <toml++/toml.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <zmq_addon.hpp>

namespace piezo::daemon {
namespace {

bool is_z85_key(const std::string& k) {
  std::array<std::uint8_t, 32> raw{};
  return k.size() == 40 && zmq_z85_decode(raw.data(), k.c_str()) != nullptr;
}

}  // namespace

KeyPair generate_keypair() {
  std::array<char, 41> pub{}, sec{};
  if (zmq_curve_keypair(pub.data(), sec.data()) != 0) {
    throw std::runtime_error("cannot make a CURVE key pair: libzmq was built without CURVE");
  }
  return {pub.data(), sec.data()};
}

namespace {

/// Writes `text` to a new file created with `mode` (a secret is never
/// readable by others, not even for a moment).
void write_new_file(const std::string& path, const std::string& text, mode_t mode) {
  ::unlink(path.c_str());  // a new inode: an old file's looser mode does not carry over
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, mode);
  if (fd < 0) throw std::runtime_error(path + ": cannot write: " + std::strerror(errno));
  const bool written = ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
  if (::close(fd) != 0 || !written) throw std::runtime_error(path + ": cannot write");
}

}  // namespace

void write_keypair(const KeyPair& keys, const std::string& dir, const std::string& name,
                   bool force) {
  const std::string secret_path = dir + "/" + name + ".key";
  const std::string public_path = dir + "/" + name + ".pub";
  // Both are checked before either is written: a refusal leaves the pair whole.
  if (!force) {
    for (const std::string& p : {secret_path, public_path}) {
      if (::access(p.c_str(), F_OK) == 0) {
        throw std::runtime_error(p +
                                 ": exists; keygen --force replaces the pair (peers that "
                                 "hold the old public key are then refused)");
      }
    }
  }
  write_new_file(secret_path,
                 "# CURVE key pair (piezod keygen): keep this file secret\n"
                 "public-key = \"" +
                     keys.public_key +
                     "\"\n"
                     "secret-key = \"" +
                     keys.secret_key + "\"\n",
                 0600);
  write_new_file(public_path,
                 "# CURVE public key (piezod keygen): give it to the peer\n"
                 "public-key = \"" +
                     keys.public_key + "\"\n",
                 0644);
}

std::string read_key(const std::string& path, const std::string& entry) {
  if (entry == "secret-key") {
    // As ssh does: a secret others can read is no longer a secret.
    struct stat st {};
    if (::stat(path.c_str(), &st) == 0 && (st.st_mode & 077) != 0) {
      throw std::runtime_error(fmt::format(
          "{}: readable by others (mode {:04o}); a secret key must be private: chmod 600 {}", path,
          st.st_mode & 07777, path));
    }
  }
  toml::table t;
  try {
    t = toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    throw std::runtime_error(path + ": not a key file (" + std::string(e.description()) + ")");
  }
  const auto key = t[entry].value<std::string>();
  if (!key) throw std::runtime_error(path + ": " + entry + ": missing");
  if (!is_z85_key(*key))
    throw std::runtime_error(path + ": " + entry + ": not a 40-character Z85 key");
  return *key;
}

std::vector<std::string> read_authorized_keys(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot read the authorized keys");
  std::vector<std::string> keys;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    // '#' is a Z85 character too: only a line that starts with it is a comment.
    line.erase(
        std::remove_if(line.begin(), line.end(), [](unsigned char c) { return std::isspace(c); }),
        line.end());
    if (line.starts_with("#")) continue;
    if (line.starts_with("public-key=")) line = line.substr(11);
    line.erase(std::remove(line.begin(), line.end(), '"'), line.end());
    if (line.empty()) continue;
    if (!is_z85_key(line)) {
      throw std::runtime_error(path + ": line " + std::to_string(n) +
                               ": not a 40-character Z85 public key");
    }
    keys.push_back(line);
  }
  return keys;
}

ZapHandler::ZapHandler(zmq::context_t& context, std::vector<std::string> authorized,
                       std::ostream& log)
    : socket_(context, zmq::socket_type::rep), authorized_(std::move(authorized)), log_(log) {
  socket_.bind("inproc://zeromq.zap.01");
}

void ZapHandler::handle() {
  std::vector<zmq::message_t> request;
  if (!zmq::recv_multipart(socket_, std::back_inserter(request), zmq::recv_flags::dontwait)) return;
  // version, request id, domain, address, routing id, mechanism, credentials
  std::string status = "400", text = "malformed ZAP request", user;
  if (request.size() >= 6) {
    const std::string mechanism = request[5].to_string();
    const std::string address = request[3].to_string();
    if (mechanism == "CURVE" && request.size() >= 7 && request[6].size() == 32) {
      std::array<char, 41> z85{};
      zmq_z85_encode(z85.data(), request[6].data<std::uint8_t>(), 32);
      user = z85.data();
      if (std::find(authorized_.begin(), authorized_.end(), user) != authorized_.end()) {
        status = "200";
        text = "OK";
      } else {
        text = "client key not authorized";
        log_ << "piezod: refused a client from " << address << ": its key " << user
             << " is not in the authorized keys\n"
             << std::flush;
      }
    } else {
      text = "only CURVE clients are admitted";
      log_ << "piezod: refused a client from " << address << " using " << mechanism << "\n"
           << std::flush;
    }
  }
  std::array<zmq::const_buffer, 6> reply{
      zmq::str_buffer("1.0"), zmq::buffer(request.size() > 1 ? request[1].to_string_view() : ""),
      zmq::buffer(status),    zmq::buffer(text),
      zmq::buffer(user),      zmq::str_buffer("")};
  zmq::send_multipart(socket_, reply);
}

}  // namespace piezo::daemon
