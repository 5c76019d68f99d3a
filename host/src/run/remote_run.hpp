#pragma once
// One run on a rig served by piezod: configure, start with a lease, renew
// it, receive the stream, fetch whatever the stream lost from the board's
// recorder, run the observer and write the log -- the same summary as an
// in-process run.

#include <atomic>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>

#include "board_client.hpp"
#include "rig_config.hpp"
#include "run_log.hpp"
#include "run_session.hpp"

namespace piezo::host {

/// The board's clock against the host's, from the fastest `clock` round trip.
struct ClockMapping {
  std::int64_t offset_ns = 0;  ///< board CLOCK_MONOTONIC - host steady clock
  std::int64_t round_trip_ns = 0;
};

[[nodiscard]] ClockMapping estimate_clock_offset(BoardClient& client, int round_trips = 16);

/// Asks the board for the config's waveform and duration; a refusal (beyond
/// the board's limits) becomes a ConfigError naming the key.
void configure_remote(const config::RigConfig& config, BoardClient& client);

/// Runs what configure_remote set up; `hello` is the daemon's hello.
[[nodiscard]] RunSummary execute_remote_run(const config::RigConfig& config, BoardClient& client,
                                            const protocol::Hello& hello, RunLog& log,
                                            const std::atomic<bool>& stop,
                                            const std::function<void(const LiveStatus&)>& on_status,
                                            std::optional<double> lease_s = std::nullopt,
                                            const std::atomic<bool>* estop = nullptr);

}  // namespace piezo::host
