#pragma once
// One run on a board served by piezod, at an address or in this process
// (the same path): its request started under a lease, the lease renewed,
// the stream received, whatever it lost fetched from the board's recorder,
// the observer run and the log written.

#include <atomic>
#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "board_client.hpp"
#include "board_request.hpp"
#include "config/config_file.hpp"
#include "io/run_log.hpp"
#include "run_session.hpp"

namespace piezo::host {

/// Stops of single axes asked for during a run (the live page's Stop of
/// one axis), from any thread; the run's loop sends each to the board.
class AxisStops {
 public:
  void request(std::string axis) {
    const std::lock_guard lock(mutex_);
    names_.push_back(std::move(axis));
  }
  [[nodiscard]] std::vector<std::string> take() {
    const std::lock_guard lock(mutex_);
    return std::exchange(names_, {});
  }

 private:
  std::mutex mutex_;
  std::vector<std::string> names_;
};

/// The board's clock against the host's, from the fastest `clock` round trip.
struct ClockMapping {
  std::int64_t offset_ns = 0;  ///< board CLOCK_MONOTONIC - host steady clock
  std::int64_t round_trip_ns = 0;
};

[[nodiscard]] ClockMapping estimate_clock_offset(BoardClient& client, int round_trips = 16);

/// Starts `request` (prepared: prepare_request) and follows it to its end;
/// `hello` is the daemon's hello. `on_rows` sees every flush interval's
/// rows as the collector made them, whether or not the log takes them (the
/// live view goes on when the log fails).
[[nodiscard]] RunSummary run_on_board(
    const config::ConfigFile& config, BoardClient& client, const protocol::Hello& hello,
    RunLog& log, const std::atomic<bool>& stop,
    const std::function<void(const LiveStatus&)>& on_status, const BoardRequest& request,
    const std::atomic<bool>* estop = nullptr,
    const std::function<void(const log_schema::AxesRows&)>& on_rows = {},
    AxisStops* axis_stops = nullptr);

}  // namespace piezo::host
