#pragma once
// The one-machine default: the firmware's daemon in this process, serving
// the same protocol on inproc://, so a local run takes the same path as a
// run on the rig's board.

#include <atomic>
#include <memory>
#include <mutex>
#include <ostream>
#include <streambuf>
#include <string>
#include <thread>
#include <zmq.hpp>

#include "config/config_file.hpp"
#include "config/rig.hpp"
#include "daemon/daemon.hpp"

namespace piezo::host {

class LocalBoard {
 public:
  /// This board's default lease (a client that names none runs under it):
  /// the host's own loop renews it, and a log flush on a slow disk must not
  /// pass for a dead host.
  static constexpr double kLease_s = 2.0;

  /// Serves `rig` with the config's own limits as the board's.
  LocalBoard(const config::ConfigFile& config, config::Rig rig);
  /// Stops the daemon (a run under way ramps down first) and joins it.
  ~LocalBoard();
  LocalBoard(const LocalBoard&) = delete;
  LocalBoard& operator=(const LocalBoard&) = delete;

  [[nodiscard]] zmq::context_t& context() { return context_; }
  [[nodiscard]] const std::string& address() const { return address_; }
  /// The daemon's event lines so far; safe while it serves.
  [[nodiscard]] std::string events() const { return events_buffer_.text(); }
  void stop();

 private:
  /// The daemon's event stream: it writes from its own thread while the
  /// host reads what it has.
  class LockedText : public std::streambuf {
   public:
    [[nodiscard]] std::string text() const;

   protected:
    int_type overflow(int_type c) override;
    std::streamsize xsputn(const char* s, std::streamsize n) override;

   private:
    mutable std::mutex mutex_;
    std::string text_;
  };

  zmq::context_t context_;
  std::string address_;
  LockedText events_buffer_;
  std::ostream events_{&events_buffer_};
  std::unique_ptr<daemon::Daemon> daemon_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace piezo::host
