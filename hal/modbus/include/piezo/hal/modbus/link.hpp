#pragma once
/// @file
/// One Modbus connection (TCP, or RTU on a serial line) through libmodbus.
/// Register calls return a Status that classifies any failure (timeout,
/// CRC, exception reply, disconnect) and never block longer than the
/// response timeout. A lost connection is re-established by a keeper thread with
/// back-off, off the real-time path: meanwhile calls return `disconnected`
/// at once. After a timeout or a reply that does not fit its request (a
/// TCP transaction id or an RTU frame that does not match), a reply may
/// still be on its way and must not be taken for the next request's: the
/// keeper resynchronises the link. On TCP it reconnects at once (a late
/// reply goes to the closed connection); on RTU, which has no transaction
/// id and where a late reply would be taken silently, it reads and discards
/// until the line has been silent for two response timeouts. A call
/// meanwhile waits for the resync, up to one response timeout, then
/// returns `disconnected`.

#include <modbus.h>

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <thread>

#include "piezo/hal/modbus/register_map.hpp"
#include "piezo/hal/status.hpp"

namespace piezo::hal::modbus {

struct LinkSettings {
  enum class Transport { tcp, rtu } transport = Transport::tcp;
  std::string host = "127.0.0.1";
  int port = 502;
  std::string device;  ///< e.g. /dev/ttyUSB0, or a pseudo-terminal
  int baud = 57600;
  char parity = 'E';  ///< 'N', 'E' or 'O'
  int data_bits = 8;
  int stop_bits = 1;
  bool rs485 = false;  ///< switch the port to RS-485 mode (ioctl TIOCSRS485)
  double response_timeout_s = 0.05;
  double byte_timeout_s = 0.01;

  /// "tcp 127.0.0.1:1502" or "rtu /dev/ttyUSB0 57600 8E1", for messages.
  [[nodiscard]] std::string describe() const;
};

class Link {
 public:
  /// The one Link of this process on a serial line (an RTU bus): every
  /// sensor on `settings.device` shares it, each at its own unit id, as
  /// sensors on one RS-485 bus do (one port cannot be opened twice). All
  /// of its users must call it from one thread (the acquire loop). Throws
  /// std::runtime_error when the line is already open with other settings
  /// (naming both). Not for TCP: each TCP user keeps its own connection.
  static std::shared_ptr<Link> on_serial_line(const LinkSettings& settings);

  /// Builds the context and connects. Throws std::runtime_error naming the
  /// link when the settings are invalid or the first connection fails.
  explicit Link(const LinkSettings& settings);
  ~Link();
  Link(const Link&) = delete;
  Link& operator=(const Link&) = delete;

  /// Reads `count` registers (function 03 or 04) into `out`. Real-time safe.
  [[nodiscard]] Status read(Function function, int unit_id, int address, int count,
                            std::uint16_t* out);
  /// Writes one holding register (function 06). Real-time safe.
  [[nodiscard]] Status write(int unit_id, int address, std::uint16_t value);

  /// Maps errno after a failed libmodbus call to a Status class.
  [[nodiscard]] static Status classify(int error);

 private:
  Status finish(int result, int error);
  /// Hands the link to the keeper after a failure that may leave it out
  /// of step; returns `s`.
  Status failed(Status s);
  /// One Modbus TCP request (its PDU) and its reply's PDU of exactly
  /// reply.size() bytes, the reply's header checked against the request.
  Status transact_tcp(int unit_id, std::span<const std::uint8_t> request,
                      std::span<std::uint8_t> reply);
  void keep_connected();
  bool try_connect();
  /// Reads and discards until the line is silent; false if it closed or errs.
  bool drain_until_silent();
  /// True when the caller owns the link, waiting out a drain under way.
  bool usable();

  LinkSettings settings_;
  modbus_t* ctx_ = nullptr;
  // The real-time caller owns ctx_ while up_ is true; the keeper owns it while false.
  std::atomic<bool> up_{false};
  std::atomic<bool> stopping_{false};
  std::atomic<bool> resync_{false};     // asks the keeper to resynchronise
  std::atomic<bool> resyncing_{false};  // from the ask until the resync has ended
  std::mutex keeper_mutex_;             // only for the keeper's sleep; never taken by a caller
  std::condition_variable keeper_wakeup_;
  std::thread keeper_;
  std::uint16_t transaction_ = 0;  ///< the last TCP transaction id sent
};

}  // namespace piezo::hal::modbus
