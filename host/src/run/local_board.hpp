#pragma once
// The one-machine default: the firmware's daemon in this process, serving
// the same protocol on inproc://, so a local run takes the same path as a
// run on the rig's board.

#include <atomic>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <zmq.hpp>

#include "daemon.hpp"
#include "rig.hpp"
#include "rig_config.hpp"

namespace piezo::host {

class LocalBoard {
 public:
  /// Serves `rig` with the config's own limits as the board's.
  LocalBoard(const config::RigConfig& config, config::Rig rig);
  /// Stops the daemon (a run under way ramps down first) and joins it.
  ~LocalBoard();
  LocalBoard(const LocalBoard&) = delete;
  LocalBoard& operator=(const LocalBoard&) = delete;

  [[nodiscard]] zmq::context_t& context() { return context_; }
  [[nodiscard]] const std::string& address() const { return address_; }
  /// The daemon's event lines so far (complete once destroyed or stopped).
  [[nodiscard]] std::string events() const;
  void stop();

 private:
  zmq::context_t context_;
  std::string address_;
  std::ostringstream events_;
  std::unique_ptr<daemon::Daemon> daemon_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace piezo::host
