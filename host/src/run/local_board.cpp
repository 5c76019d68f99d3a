#include "local_board.hpp"

#include <unistd.h>

#include <algorithm>

namespace piezo::host {
namespace {

config::RigConfig board_config(const config::RigConfig& c) {
  config::RigConfig board = c;
  // The config's own limits are the board's; only the run's length is the host's to choose.
  board.daemon.duration_max_s = std::max(board.daemon.duration_max_s, c.run.duration_s);
  return board;
}

std::string inproc_address() {
  static std::atomic<int> count{0};
  return "inproc://piezod-" + std::to_string(getpid()) + "-" + std::to_string(count++);
}

}  // namespace

LocalBoard::LocalBoard(const config::RigConfig& config, config::Rig rig)
    : address_(inproc_address()),
      daemon_(std::make_unique<daemon::Daemon>(board_config(config), std::move(rig), context_,
                                               address_, events_)),
      thread_([this] { daemon_->serve(stop_); }) {}

LocalBoard::~LocalBoard() {
  stop();
}

void LocalBoard::stop() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

std::string LocalBoard::events() const {
  return events_.str();
}

}  // namespace piezo::host
