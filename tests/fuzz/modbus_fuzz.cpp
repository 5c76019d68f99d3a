// libFuzzer target: what the rig reads from a Modbus device.
//  - Register decoding: any words in any type and word order decode to a
//    number, and a value encoded by our server side decodes back.
//  - Response handling: the sensor (libmodbus under our Link) reads from a
//    loopback TCP peer that answers each request with the fuzzer's bytes
//    (its MBAP transaction id copied from the request, so that libmodbus
//    looks past it). Every answer must end as a reading or a classified
//    error -- never a crash, a hang or an exception.
// Input: byte 0 picks the register type, word order and function; then the
// response bytes.
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <mutex>
#include <span>
#include <thread>
#include <vector>

#include "piezo/hal/modbus/modbus_sensor.hpp"
#include "piezo/hal/modbus/register_map.hpp"
#include "piezo/hal/posix/monotonic_clock.hpp"

using namespace piezo::hal;
using namespace piezo::hal::modbus;

namespace {

/// A loopback TCP peer on its own thread: accepts the sensors' connections
/// and answers every request with the bytes of the current input.
class FuzzPeer {
 public:
  FuzzPeer() {
    listener_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::bind(listener_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
        ::listen(listener_, 16) != 0) {
      std::abort();
    }
    socklen_t len = sizeof a;
    ::getsockname(listener_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
    std::thread([this] { serve(); }).detach();
  }
  [[nodiscard]] int port() const { return port_; }
  void set_response(std::span<const std::uint8_t> bytes) {
    const std::lock_guard lock(mutex_);
    response_.assign(bytes.begin(), bytes.end());
  }

 private:
  void serve() {
    std::vector<pollfd> fds{{listener_, POLLIN, 0}};
    for (;;) {
      if (::poll(fds.data(), fds.size(), -1) <= 0) continue;
      if (fds[0].revents & POLLIN)
        fds.push_back({::accept(listener_, nullptr, nullptr), POLLIN, 0});
      for (std::size_t i = 1; i < fds.size(); ++i) {
        if (!(fds[i].revents & (POLLIN | POLLHUP | POLLERR))) continue;
        std::uint8_t request[260];
        const ssize_t n = ::recv(fds[i].fd, request, sizeof request, 0);
        if (n <= 0) {
          ::close(fds[i].fd);
          fds.erase(fds.begin() + static_cast<std::ptrdiff_t>(i--));
          continue;
        }
        std::vector<std::uint8_t> out;
        {
          const std::lock_guard lock(mutex_);
          out = response_;
        }
        if (out.size() >= 2 && n >= 2) std::memcpy(out.data(), request, 2);  // transaction id
        if (!out.empty()) (void)::send(fds[i].fd, out.data(), out.size(), MSG_NOSIGNAL);
      }
    }
  }
  int listener_ = -1, port_ = 0;
  std::mutex mutex_;
  std::vector<std::uint8_t> response_;
};

void check_decoding(RegisterType type, WordOrder order, std::span<const std::uint16_t> words) {
  if (words.size() < 2) return;
  const double v = decode(type, order, words);
  if (type != RegisterType::f32 && !std::isfinite(v)) std::abort();
  if (std::isfinite(v)) {
    std::uint16_t again[2]{};
    encode(type, order, v, again);
    if (decode(type, order, again) != v) std::abort();  // integers and floats are exact
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const auto type = static_cast<RegisterType>(data[0] % 5);
  const auto order = static_cast<WordOrder>((data[0] / 5) % 4);
  const auto function = data[0] & 0x80 ? Function::holding : Function::input;
  const std::span<const std::uint8_t> bytes(data + 1, size - 1);

  std::uint16_t words[2]{};
  std::memcpy(words, bytes.data(), std::min<std::size_t>(bytes.size(), sizeof words));
  check_decoding(type, order, words);

  // One peer for the whole run, one sensor per register type and function;
  // a sensor reconnects by itself after an answer that made libmodbus drop
  // the connection.
  static FuzzPeer peer;
  static const posix::MonotonicClock clock;
  static std::unique_ptr<ModbusSensor> sensors[5][4][2];
  auto& sensor = sensors[static_cast<int>(type)][static_cast<int>(order)][data[0] >> 7];
  if (!sensor) {
    LinkSettings link;
    link.port = peer.port();
    link.response_timeout_s = 0.005;
    link.byte_timeout_s = 0.002;
    RegisterMap map;
    map.function = function;
    map.type = type;
    map.order = order;
    map.scale = 1e-6;
    sensor = std::make_unique<ModbusSensor>(link, map, clock);
  }
  peer.set_response(bytes);
  const DisplacementReading r = sensor->read();
  if (r.status == Status::ok && !std::isfinite(r.displacement_m) && type != RegisterType::f32) {
    std::abort();
  }
  return 0;
}
