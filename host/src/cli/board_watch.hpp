#pragma once
// `piezo view --rig`: the live page of whatever a board runs, watched from a
// second host without driving it. Subscribes to piezod's stream, rebuilds
// the angle (tared at each run's first good reading) and the observer as
// `piezo run` does, and feeds the live page. With control: e-stop (any
// client may), and move-to, whose lease it then keeps, and stop of that move.

#include <chrono>
#include <deque>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>

#include "config/config_file.hpp"
#include "run/board_client.hpp"
#include "run/observer_stage.hpp"
#include "run/sample_collector.hpp"
#include "run/stream_follower.hpp"
#include "view/live_feed.hpp"

namespace piezo::host {

class BoardWatch {
 public:
  /// `hello` is the board's answer to `hello` (rates, latency).
  BoardWatch(const config::ConfigFile& config, BoardClient& client, const protocol::Hello& hello,
             view::LiveFeed& feed);

  /// Handles what the stream brought within `wait`, and renews the lease of
  /// a move this watch started. The watch's own thread.
  void poll(std::chrono::milliseconds wait);

  // From the web server's threads; each returns the board's reply or throws.
  nlohmann::json estop();
  /// The run's stop, or (`args` {"axis": NAME}) one axis's of it.
  nlohmann::json stop(const nlohmann::json& args);
  nlohmann::json move_to(const nlohmann::json& args);
  /// The board's dictionary (`describe`), asked when the watch began and
  /// again when the board restarted.
  [[nodiscard]] nlohmann::json dictionary();

 private:
  /// A restarted board (its health names another board_id) is a new board:
  /// its hello and dictionary are read again, and nothing of the old one's
  /// runs is followed, renewed or shown as current.
  void meet_new_board();
  void follow_run(std::uint64_t run);
  [[nodiscard]] bool controlling();
  [[nodiscard]] nlohmann::json lease_json();  ///< the lease of a move this watch started, or null
  void on_state(const protocol::StateEvent& state);
  nlohmann::json call(const std::string& cmd,
                      const nlohmann::json& args = nlohmann::json::object());

  config::ConfigFile config_;
  BoardClient& client_;
  protocol::Hello hello_;
  view::LiveFeed& feed_;
  std::mutex commands_;  ///< the command socket, shared by the watch and the page
  nlohmann::json dictionary_;  ///< under commands_

  /// One axis of the run watched: its angle (its own radius) and observer.
  struct WatchedAxis {
    WatchedAxis(std::string axis_name, hal::TimeNs t0, double r2,
                std::unique_ptr<ObserverStage> stage)
        : name(std::move(axis_name)),
          observer(std::move(stage)),
          collector(t0, r2, observer.get()) {}
    std::string name;
    std::unique_ptr<ObserverStage> observer;
    SampleCollector collector;
  };
  std::optional<std::uint64_t> run_;
  std::deque<WatchedAxis> axes_;  ///< the run's, in its order (never moved: collectors point in)
  StreamFollower follower_;       ///< after commands_: its fetches go through call()
  nlohmann::json last_summary_;   ///< the last run's end, kept across health updates
  nlohmann::json health_ = nlohmann::json::object();

  // Under commands_: the page's threads start a move, the watch renews it.
  std::optional<std::uint64_t> controlled_run_;  ///< a move this watch started
  double lease_s_ = 0.0;                         ///< the started move's
  std::chrono::steady_clock::time_point last_lease_;
};

}  // namespace piezo::host
