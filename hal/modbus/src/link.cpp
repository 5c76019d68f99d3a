#include "piezo/hal/modbus/link.hpp"

#include <sys/select.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <ctime>
#include <stdexcept>
#include <system_error>

namespace piezo::hal::modbus {
namespace {

void set_timeout(modbus_t* ctx, double seconds, int (*setter)(modbus_t*, uint32_t, uint32_t)) {
  const auto whole = static_cast<uint32_t>(seconds);
  const auto micro = static_cast<uint32_t>(std::lround((seconds - whole) * 1e6));
  setter(ctx, whole, micro);
}

}  // namespace

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
  if (result >= 0) return Status::ok;
  const Status s = classify(error);
  // A reply may still be on its way (timeout), or one already came for an
  // earlier request (a mismatched reply): hand the context to the keeper,
  // which drains the line before the next request goes out.
  if (s == Status::timeout || s == Status::io_error || s == Status::crc_error) {
    resyncing_.store(true);
    resync_.store(true);
    up_.store(false, std::memory_order_release);
    keeper_wakeup_.notify_one();
  }
  // Hand the context to the keeper, which reconnects.
  if (s == Status::disconnected) up_.store(false, std::memory_order_release);
  return s;
}

Status Link::read(Function function, int unit_id, int address, int count, std::uint16_t* out) {
  if (!usable()) return Status::disconnected;
  modbus_set_slave(ctx_, unit_id);
  const int n = function == Function::input ? modbus_read_input_registers(ctx_, address, count, out)
                                            : modbus_read_registers(ctx_, address, count, out);
  return finish(n == count ? n : -1, n == count ? 0 : errno);
}

Status Link::write(int unit_id, int address, std::uint16_t value) {
  if (!usable()) return Status::disconnected;
  modbus_set_slave(ctx_, unit_id);
  const int n = modbus_write_register(ctx_, address, value);
  return finish(n, n >= 0 ? 0 : errno);
}

}  // namespace piezo::hal::modbus
