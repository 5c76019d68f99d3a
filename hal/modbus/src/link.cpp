#include "piezo/hal/modbus/link.hpp"

#include <cerrno>
#include <chrono>
#include <cmath>
#include <stdexcept>

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
  keeper_ = std::thread([this] { keep_connected(); });
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

// Waits for a lost link, then reconnects with back-off from 50 ms to 2 s.
void Link::keep_connected() {
  using namespace std::chrono_literals;
  std::unique_lock lock(keeper_mutex_);
  auto backoff = 50ms;
  while (!stopping_) {
    keeper_wakeup_.wait_for(lock, up_.load() ? 20ms : backoff);
    if (stopping_ || up_.load(std::memory_order_acquire)) {
      backoff = 50ms;
      continue;
    }
    modbus_close(ctx_);
    if (!try_connect()) backoff = std::min(backoff * 2, std::chrono::milliseconds(2000));
  }
}

Status Link::finish(int result, int error) {
  if (result >= 0) return Status::ok;
  const Status s = classify(error);
  // A reply that comes late must not be taken for the next one.
  if (s == Status::timeout) modbus_flush(ctx_);
  // Hand the context to the keeper, which reconnects.
  if (s == Status::disconnected) up_.store(false, std::memory_order_release);
  return s;
}

Status Link::read(Function function, int unit_id, int address, int count, std::uint16_t* out) {
  if (!up_.load(std::memory_order_acquire)) return Status::disconnected;
  modbus_set_slave(ctx_, unit_id);
  const int n = function == Function::input ? modbus_read_input_registers(ctx_, address, count, out)
                                            : modbus_read_registers(ctx_, address, count, out);
  return finish(n == count ? n : -1, n == count ? 0 : errno);
}

Status Link::write(int unit_id, int address, std::uint16_t value) {
  if (!up_.load(std::memory_order_acquire)) return Status::disconnected;
  modbus_set_slave(ctx_, unit_id);
  const int n = modbus_write_register(ctx_, address, value);
  return finish(n, n >= 0 ? 0 : errno);
}

}  // namespace piezo::hal::modbus
