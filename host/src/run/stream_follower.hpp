#pragma once
// Follows a board's stream (docs/protocol.md, "Stream"): samples kept in
// sequence into a SampleCollector (a frame that skips ahead has its gap
// fetched from the board's recorder first, repeats are dropped), the
// latest health, the state events, and when the board was last heard. One
// follower for every host that watches a run: `piezo run --rig`, `step`,
// `move`, `calibrate` (the run's controller) and `piezo view --rig` (a
// watcher).

#include <chrono>
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "board_client.hpp"
#include "piezo/protocol/frame.hpp"
#include "piezo/protocol/messages.hpp"
#include "sample_collector.hpp"

namespace piezo::host {

class StreamFollower {
 public:
  using SteadyClock = std::chrono::steady_clock;
  /// Sends a command and returns its reply (the client's `call`, or a
  /// caller's that serialises the command socket among threads).
  using Call = std::function<nlohmann::json(const std::string& cmd, const nlohmann::json& args)>;

  StreamFollower(BoardClient& client, Call call) : client_(client), call_(std::move(call)) {}
  /// Subscribes `client` to the samples, state and health (before a run's
  /// start, so that its first samples come).
  static void subscribe(BoardClient& client);

  /// Follows a new run: each sample goes to its axis's collector,
  /// `by_axis[sample.axis]` (the board's axis index; a null or missing one:
  /// dropped), each of which must outlive the follower's use of it, stamped
  /// with `received_s()`. The run's
  /// controller follows it from sample 0; a watcher that joins a run under
  /// way (`from_sample_zero` false) from the first frame it sees, and skips
  /// (and notes) a gap the board will not serve it (its fetch budget).
  void follow(std::vector<SampleCollector*> by_axis, std::function<double()> received_s,
              bool from_sample_zero = true);

  /// What drain() tells its caller; each may be left empty.
  struct Handlers {
    std::function<bool()> keep_going;  ///< false: no more now (a lease falls due)
    std::function<void()> on_heard;    ///< a message arrived (before it is handled)
    std::function<void(const protocol::StateEvent&)> on_state;
    std::function<void(const protocol::HealthEvent&)> on_health;
    std::function<void(const protocol::TriggerEvent&)> on_trigger;  ///< a scan's pulse
    /// Before a gap is fetched: a fetch after an outage takes as long as
    /// the outage's samples take to send and decode, and the caller's lease
    /// must not wait behind it.
    std::function<void()> before_fetch;
  };
  /// Handles what arrives within `wait`, at most `max_messages` messages.
  void drain(std::chrono::milliseconds wait, int max_messages, const Handlers& handlers);
  /// Fetches whatever of `stream` up to `end` was not yet received (the
  /// tail of a finished run, published while the link was down).
  void fetch(protocol::Stream stream, std::uint64_t end);

  /// The board's latest health event (state "running" until one came).
  [[nodiscard]] const protocol::HealthEvent& health() const { return health_; }
  [[nodiscard]] std::uint64_t drive_next() const { return drive_next_; }
  [[nodiscard]] std::uint64_t sensor_next() const { return sensor_next_; }
  /// When anything last came from the board.
  [[nodiscard]] SteadyClock::time_point last_heard() const { return last_heard_; }
  /// Marks the board heard (it answered a command).
  void heard() { last_heard_ = SteadyClock::now(); }
  /// Gaps fetched, as "stream [first, end)".
  [[nodiscard]] const std::vector<std::string>& gaps() const { return gaps_; }

 private:
  void on_frame(std::string_view frame, const Handlers& handlers);
  void add(std::string_view frame, const protocol::FrameHeader& header);

  BoardClient& client_;
  Call call_;
  [[nodiscard]] SampleCollector* collector(std::uint8_t axis) const {
    return axis < collectors_.size() ? collectors_[axis] : nullptr;
  }
  std::vector<SampleCollector*> collectors_;  ///< by the board's axis index
  std::function<double()> received_s_;
  bool from_sample_zero_ = true;
  bool drive_started_ = false, sensor_started_ = false;  ///< a frame of each stream was seen
  protocol::HealthEvent health_ = [] {
    protocol::HealthEvent e;
    e.state = protocol::BoardState::running;
    return e;
  }();
  std::uint64_t drive_next_ = 0, sensor_next_ = 0;
  SteadyClock::time_point last_heard_ = SteadyClock::now();
  std::vector<std::string> gaps_;
};

}  // namespace piezo::host
