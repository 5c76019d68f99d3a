#include "piezo/hal/modbus/link.hpp"

#include <fmt/format.h>
#include <poll.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <ctime>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <system_error>

#include "piezo/hal/modbus/mbap.hpp"

namespace piezo::hal::modbus {
namespace {

void set_timeout(modbus_t* ctx, double seconds, int (*setter)(modbus_t*, uint32_t, uint32_t)) {
  const auto whole = static_cast<uint32_t>(seconds);
  const auto micro = static_cast<uint32_t>(std::lround((seconds - whole) * 1e6));
  setter(ctx, whole, micro);
}

}  // namespace

std::shared_ptr<Link> Link::on_serial_line(const LinkSettings& settings) {
  // Opened once per line; the last user's release closes it.
  static std::mutex lines_mutex;
  static std::map<std::string, std::weak_ptr<Link>> lines;
  const std::lock_guard lock(lines_mutex);
  if (const auto open = lines[settings.device].lock()) {
    if (open->settings_.describe() != settings.describe()) {
      throw std::runtime_error(fmt::format(
          "modbus: {} is open as {}; a sensor asks it as {}: one line has one set of settings",
          settings.device, open->settings_.describe(), settings.describe()));
    }
    return open;
  }
  auto link = std::make_shared<Link>(settings);
  lines[settings.device] = link;
  return link;
}

std::string LinkSettings::describe() const {
  if (transport == Transport::tcp) return "tcp " + host + ":" + std::to_string(port);
  return "rtu " + device + " " + std::to_string(baud) + " " + std::to_string(data_bits) + parity +
         std::to_string(stop_bits);
}

Status Link::classify(int error) {
  if (error == ETIMEDOUT || error == EAGAIN) return Status::timeout;
  if (error == EMBBADCRC) return Status::crc_error;
  if (error >= EMBXILFUN && error <= EMBXGTAR) return Status::exception_reply;
  if (error == ECONNRESET || error == EPIPE || error == ECONNREFUSED || error == EBADF ||
      error == ENOTCONN || error == ECONNABORTED) {
    return Status::disconnected;
  }
  return Status::io_error;
}

Link::Link(const LinkSettings& settings) : settings_(settings) {
  if (settings.transport == LinkSettings::Transport::tcp) {
    ctx_ = modbus_new_tcp(settings.host.c_str(), settings.port);
  } else {
    ctx_ = modbus_new_rtu(settings.device.c_str(), settings.baud, settings.parity,
                          settings.data_bits, settings.stop_bits);
  }
  if (ctx_ == nullptr) {
    throw std::runtime_error("modbus " + settings.describe() + ": " + modbus_strerror(errno));
  }
  set_timeout(ctx_, settings.response_timeout_s, modbus_set_response_timeout);
  set_timeout(ctx_, settings.byte_timeout_s, modbus_set_byte_timeout);
  if (!try_connect()) {
    const std::string why = modbus_strerror(errno);
    modbus_free(ctx_);
    throw std::runtime_error("modbus " + settings.describe() + ": cannot connect: " + why);
  }
  try {
    keeper_ = std::thread([this] { keep_connected(); });
  } catch (const std::system_error& e) {
    modbus_close(ctx_);
    modbus_free(ctx_);
    throw std::runtime_error("modbus " + settings.describe() +
                             ": cannot start the link keeper: " + e.what());
  }
}

Link::~Link() {
  {
    std::lock_guard lock(keeper_mutex_);
    stopping_ = true;
  }
  keeper_wakeup_.notify_all();
  keeper_.join();
  modbus_close(ctx_);
  modbus_free(ctx_);
}

bool Link::try_connect() {
  if (modbus_connect(ctx_) != 0) return false;
  if (settings_.transport == LinkSettings::Transport::rtu && settings_.rs485 &&
      modbus_rtu_set_serial_mode(ctx_, MODBUS_RTU_RS485) != 0) {
    modbus_close(ctx_);
    return false;
  }
  up_.store(true, std::memory_order_release);
  return true;
}

bool Link::drain_until_silent() {
  // Bounded: a device that never falls silent is reconnected instead.
  constexpr auto kLongest = std::chrono::seconds(2);
  const auto give_up = std::chrono::steady_clock::now() + kLongest;
  const int fd = modbus_get_socket(ctx_);
  const auto quiet_us = static_cast<long>(2.0 * settings_.response_timeout_s * 1e6);
  while (fd >= 0 && std::chrono::steady_clock::now() < give_up) {
    fd_set readable;
    FD_ZERO(&readable);
    FD_SET(fd, &readable);
    timeval quiet{quiet_us / 1'000'000, quiet_us % 1'000'000};
    const int ready = select(fd + 1, &readable, nullptr, nullptr, &quiet);
    if (ready == 0) return true;
    if (ready < 0 && errno == EINTR) continue;
    std::uint8_t discard[256];
    if (ready < 0 || ::read(fd, discard, sizeof discard) <= 0) return false;
  }
  return false;
}

// Waits for a lost or unsynchronised link: drains an RTU line that may
// still carry a late reply; reconnects a lost link with back-off from 50 ms
// to 2 s, and a TCP link to resynchronise it at once.
void Link::keep_connected() {
  using namespace std::chrono_literals;
  std::unique_lock lock(keeper_mutex_);
  auto backoff = 50ms;
  while (!stopping_) {
    if (!resync_.load()) keeper_wakeup_.wait_for(lock, up_.load() ? 20ms : backoff);
    if (stopping_ || up_.load(std::memory_order_acquire)) {
      backoff = 50ms;
      continue;
    }
    const bool rtu = settings_.transport == LinkSettings::Transport::rtu;
    if (resync_.exchange(false) && rtu && drain_until_silent()) {
      up_.store(true, std::memory_order_release);
      resyncing_.store(false);
      continue;
    }
    modbus_close(ctx_);
    if (!try_connect()) backoff = std::min(backoff * 2, std::chrono::milliseconds(2000));
    resyncing_.store(false);
  }
}

bool Link::usable() {
  if (up_.load(std::memory_order_acquire)) return true;
  if (!resyncing_.load()) return false;
  // Wait as long as a request could, rather than fail every call meanwhile.
  const auto wait_until = std::chrono::steady_clock::now() +
                          std::chrono::duration<double>(settings_.response_timeout_s);
  const timespec step{0, 1'000'000};
  while (resyncing_.load() && std::chrono::steady_clock::now() < wait_until) {
    nanosleep(&step, nullptr);
  }
  return up_.load(std::memory_order_acquire);
}

Status Link::finish(int result, int error) {
  return result >= 0 ? Status::ok : failed(classify(error));
}

Status Link::failed(Status s) {
  // A reply may still be on its way (timeout), or one already came for an
  // earlier request (a mismatched reply): hand the context to the keeper,
  // which drains the line or reconnects before the next request goes out.
  if (s == Status::timeout || s == Status::io_error || s == Status::crc_error ||
      s == Status::bad_reply) {
    resyncing_.store(true);
    resync_.store(true);
    up_.store(false, std::memory_order_release);
    keeper_wakeup_.notify_one();
  }
  // Hand the context to the keeper, which reconnects.
  if (s == Status::disconnected) up_.store(false, std::memory_order_release);
  return s;
}

namespace {

/// Reads exactly `n` bytes before `deadline`; false on a timeout (errno
/// ETIMEDOUT) or a closed or failed socket (errno says which).
bool read_exactly(int fd, std::uint8_t* out, std::size_t n,
                  std::chrono::steady_clock::time_point deadline) {
  for (std::size_t got = 0; got < n;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    pollfd p{fd, POLLIN, 0};
    const int ready = left.count() > 0 ? poll(&p, 1, static_cast<int>(left.count())) : 0;
    if (ready < 0 && errno == EINTR) continue;
    if (ready == 0) {
      errno = ETIMEDOUT;
      return false;
    }
    const ssize_t r = ready < 0 ? -1 : ::recv(fd, out + got, n - got, 0);
    if (r == 0) errno = ECONNRESET;
    if (r <= 0) return false;
    got += static_cast<std::size_t>(r);
  }
  return true;
}

}  // namespace

// libmodbus frames a TCP reply by its function code and lets its header
// pass unchecked (the protocol id test reads `&&` for `||`), so a reply
// with another unit id, protocol id or length would be taken as good. The
// TCP transaction is ours: the whole header is checked against the request.
Status Link::transact_tcp(int unit_id, std::span<const std::uint8_t> request,
                          std::span<std::uint8_t> reply) {
  const int fd = modbus_get_socket(ctx_);
  const std::uint16_t tid = ++transaction_;
  std::array<std::uint8_t, kMaxTcpFrame> frame{};
  const auto length = static_cast<std::uint16_t>(1 + request.size());
  const std::array<std::uint8_t, kMbapBytes> head{static_cast<std::uint8_t>(tid >> 8),
                                                  static_cast<std::uint8_t>(tid & 0xff),
                                                  0,
                                                  0,
                                                  static_cast<std::uint8_t>(length >> 8),
                                                  static_cast<std::uint8_t>(length & 0xff),
                                                  static_cast<std::uint8_t>(unit_id)};
  std::copy(head.begin(), head.end(), frame.begin());
  std::copy(request.begin(), request.end(), frame.begin() + kMbapBytes);
  const std::size_t frame_bytes = kMbapBytes + request.size();
  if (::send(fd, frame.data(), frame_bytes, MSG_NOSIGNAL) != static_cast<ssize_t>(frame_bytes)) {
    return failed(classify(errno));
  }
  const auto now = std::chrono::steady_clock::now();
  const auto response_deadline =
      now + std::chrono::duration_cast<std::chrono::nanoseconds>(
                std::chrono::duration<double>(settings_.response_timeout_s));
  std::array<std::uint8_t, kMaxTcpFrame> in{};
  if (!read_exactly(fd, in.data(), kMbapBytes, response_deadline)) return failed(classify(errno));
  const Mbap h = read_mbap(in);
  if (h.transaction != tid || h.protocol != 0 || h.unit != unit_id || h.length < 2 ||
      h.length > kMaxMbapLength) {
    return failed(Status::bad_reply);
  }
  const auto byte_deadline =
      std::max(response_deadline, std::chrono::steady_clock::now() +
                                      std::chrono::duration_cast<std::chrono::nanoseconds>(
                                          std::chrono::duration<double>(settings_.byte_timeout_s)));
  const std::size_t pdu_bytes = h.length - 1u;
  if (!read_exactly(fd, in.data() + kMbapBytes, pdu_bytes, byte_deadline)) {
    return failed(classify(errno));
  }
  const std::uint8_t function = in[kMbapBytes];
  if (function == (request[0] | 0x80) && pdu_bytes == 2) return Status::exception_reply;
  if (function != request[0] || pdu_bytes != reply.size()) return failed(Status::bad_reply);
  std::copy_n(in.begin() + kMbapBytes, pdu_bytes, reply.begin());
  return Status::ok;
}

Status Link::read(Function function, int unit_id, int address, int count, std::uint16_t* out) {
  if (!usable()) return Status::disconnected;
  if (settings_.transport == LinkSettings::Transport::tcp) {
    const auto code = static_cast<std::uint8_t>(function == Function::input ? 4 : 3);
    const std::array<std::uint8_t, 5> request{
        code, static_cast<std::uint8_t>(address >> 8), static_cast<std::uint8_t>(address & 0xff),
        static_cast<std::uint8_t>(count >> 8), static_cast<std::uint8_t>(count & 0xff)};
    std::array<std::uint8_t, 2 + 2 * 125> reply{};
    const auto used = static_cast<std::size_t>(2 + 2 * count);
    const Status s = transact_tcp(unit_id, request, std::span(reply.data(), used));
    if (s != Status::ok) return s;
    if (reply[1] != 2 * count) return failed(Status::bad_reply);
    for (int i = 0; i < count; ++i) {
      out[i] = static_cast<std::uint16_t>(reply[2 + 2 * i] << 8 | reply[3 + 2 * i]);
    }
    return Status::ok;
  }
  modbus_set_slave(ctx_, unit_id);
  const int n = function == Function::input ? modbus_read_input_registers(ctx_, address, count, out)
                                            : modbus_read_registers(ctx_, address, count, out);
  return finish(n == count ? n : -1, n == count ? 0 : errno);
}

Status Link::write(int unit_id, int address, std::uint16_t value) {
  if (!usable()) return Status::disconnected;
  if (settings_.transport == LinkSettings::Transport::tcp) {
    const std::array<std::uint8_t, 5> request{
        6, static_cast<std::uint8_t>(address >> 8), static_cast<std::uint8_t>(address & 0xff),
        static_cast<std::uint8_t>(value >> 8), static_cast<std::uint8_t>(value & 0xff)};
    std::array<std::uint8_t, 5> reply{};
    const Status s = transact_tcp(unit_id, request, reply);
    if (s != Status::ok) return s;
    return reply == request ? Status::ok : failed(Status::bad_reply);  // the echo
  }
  modbus_set_slave(ctx_, unit_id);
  const int n = modbus_write_register(ctx_, address, value);
  return finish(n, n >= 0 ? 0 : errno);
}

}  // namespace piezo::hal::modbus
