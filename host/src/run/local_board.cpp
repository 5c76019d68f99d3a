#include "local_board.hpp"

#include <unistd.h>

#include <algorithm>

namespace piezo::host {
namespace {

config::BoardConfig board_config(const config::ConfigFile& c) {
  config::BoardConfig board = c.board;
  // The config's own limits are the board's; only the run's length is the host's to choose.
  board.daemon.duration_max_s = std::max(board.daemon.duration_max_s, c.host.run.duration_s);
  board.daemon.lease_s = LocalBoard::kLease_s;
  board.daemon.lease_max_s = std::max(board.daemon.lease_max_s, LocalBoard::kLease_s);
  return board;
}

std::string inproc_address() {
  static std::atomic<int> count{0};
  return "inproc://piezod-" + std::to_string(getpid()) + "-" + std::to_string(count++);
}

}  // namespace

LocalBoard::LocalBoard(const config::ConfigFile& config, config::Rig rig)
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

std::string LocalBoard::LockedText::text() const {
  const std::lock_guard lock(mutex_);
  return text_;
}

LocalBoard::LockedText::int_type LocalBoard::LockedText::overflow(int_type c) {
  if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
  const std::lock_guard lock(mutex_);
  text_.push_back(traits_type::to_char_type(c));
  return c;
}

std::streamsize LocalBoard::LockedText::xsputn(const char* s, std::streamsize n) {
  const std::lock_guard lock(mutex_);
  text_.append(s, static_cast<std::size_t>(n));
  return n;
}

}  // namespace piezo::host
