#include "board_watch.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>
#include <zmq_addon.hpp>

#include "piezo/firmware/wire_keys.hpp"
#include "piezo/protocol/dictionary.hpp"
#include "piezo/protocol/frame.hpp"
#include "piezo/protocol/message.hpp"

namespace piezo::host {
using nlohmann::json;

BoardWatch::BoardWatch(const config::ConfigFile& config, BoardClient& client,
                       const protocol::Hello& hello, view::LiveFeed& feed)
    : config_(config),
      client_(client),
      hello_(hello),
      feed_(feed),
      dictionary_(client.call("describe")),
      follower_(client,
                [this](const std::string& cmd, const json& args) { return call(cmd, args); }) {
  StreamFollower::subscribe(client_);
}

json BoardWatch::dictionary() {
  const std::lock_guard lock(commands_);
  return dictionary_;
}

void BoardWatch::meet_new_board() {
  const std::lock_guard lock(commands_);
  hello_ = client_.hello();
  dictionary_ = client_.call("describe");
  controlled_run_.reset();  // its lease is the old board's: nothing to renew
  run_.reset();
  last_summary_ = nullptr;
}

json BoardWatch::call(const std::string& cmd, const json& args) {
  const std::lock_guard lock(commands_);
  return client_.call(cmd, args);
}

void BoardWatch::follow_run(std::uint64_t run) {
  const auto status = protocol::decode<protocol::Status>(call("status"));
  if (!status.run || status.run->id != run) return;
  run_ = run;
  last_summary_ = nullptr;
  health_.erase(wire_key::summary);
  const hal::TimeNs t0 = status.run->t0_ns;
  // The run's axes, one or several.
  const std::vector<std::string>& names = status.run->axes;
  axes_.clear();
  std::vector<SampleCollector*> by_axis(hello_.axes.size());
  for (const std::string& name : names) {
    std::size_t index = 0;
    while (index < hello_.axes.size() && hello_.axes[index].name != name) ++index;
    if (index == hello_.axes.size()) continue;  // an axis its hello lacks: nothing to show for it
    const double r2 = hello_.axes[index].r2_m;
    std::unique_ptr<ObserverStage> observer;
    if (config_.host.observer.enabled) {
      // The config's own axis of that name, where it describes several.
      const config::AxisConfig* own = config_.board.find_axis(name);
      observer = std::make_unique<ObserverStage>(
          own != nullptr ? own->model.motor : config_.host.model.motor, config_.host.observer.gains,
          1.0 / hello_.drive_rate_hz, hello_.output_latency_s);
    }
    by_axis.at(index) = &axes_.emplace_back(name, t0, r2, std::move(observer)).collector;
  }
  feed_.set_axes(names);
  follower_.follow(
      std::move(by_axis), [] { return std::numeric_limits<double>::quiet_NaN(); }, false);
}

void BoardWatch::on_state(const protocol::StateEvent& state) {
  if (state.state == protocol::BoardState::running && state.run && *state.run != run_.value_or(0)) {
    follow_run(*state.run);
  }
  if (state.summary && state.run) {
    const std::lock_guard lock(commands_);
    if (*state.run == controlled_run_.value_or(0)) {
      controlled_run_.reset();  // the move this watch started has ended
    }
  }
  health_[wire_key::state] = protocol::to_string(state.state);
  if (state.summary) {
    health_[wire_key::summary] = last_summary_ = *state.summary;
  }
}

void BoardWatch::poll(std::chrono::milliseconds wait) {
  StreamFollower::Handlers handlers;
  handlers.on_health = [this](const protocol::HealthEvent& health) {
    if (!health.board_id.empty() && health.board_id != hello_.board_id) meet_new_board();
    // The periodic health replaces the last; the end of the last run (its
    // summary, from the state event) stays until the next starts.
    health_ = health;
    if (!last_summary_.is_null()) health_[wire_key::summary] = last_summary_;
  };
  handlers.on_state = [this](const protocol::StateEvent& state) { on_state(state); };
  follower_.drain(wait, 256, handlers);
  // A run already under way when the watch started: its start event was missed.
  if (!run_ &&
      health_.value(wire_key::state, "") == protocol::to_string(protocol::BoardState::running)) {
    const auto status = protocol::decode<protocol::Status>(call("status"));
    if (status.run) follow_run(status.run->id);
  }
  {
    const std::lock_guard lock(commands_);
    if (controlled_run_ && std::chrono::steady_clock::now() - last_lease_ >=
                               std::chrono::duration<double>(lease_s_ / 4.0)) {
      client_.send("lease", protocol::LeaseRequest{follower_.drive_next()});
      last_lease_ = std::chrono::steady_clock::now();
    }
  }
  if (!axes_.empty()) {
    log_schema::AxesRows rows;
    double t = 0.0;
    for (WatchedAxis& a : axes_) {
      rows.push_back(std::exchange(a.collector.rows(), {}));
      t = std::max(t, a.collector.last_t());
    }
    feed_.add(rows);
    // The readout's: the run's first axis (a group's others have their plots).
    const WatchedAxis& first = axes_.front();
    feed_.set_status(
        {{"t_s", t},
         {"V", first.collector.last_V()},
         {"theta_rad", first.collector.last_theta()},
         {"residual_rad", first.observer ? first.observer->summary().last_residual_rad : 0.0},
         {"sensor_samples", follower_.sensor_next()},
         {"sensor_errors",
          health_.value(wire_key::sensor, json::object()).value(wire_key::errors, 0)},
         {wire_key::board, health_},
         {"errors_by_class",
          {{wire_key::drive, first.collector.drive_errors()},
           {wire_key::sensor, first.collector.sensor_errors()}}},
         {wire_key::lease_s, lease_json()}});
  } else {
    feed_.set_status({{wire_key::board, health_}});
  }
}

json BoardWatch::estop() {
  return call("estop");
}

json BoardWatch::lease_json() {
  const std::lock_guard lock(commands_);
  return controlled_run_ ? json(lease_s_) : json(nullptr);
}

bool BoardWatch::controlling() {
  const std::lock_guard lock(commands_);
  return controlled_run_.has_value();
}

json BoardWatch::stop(const json& args) {
  if (!controlling()) {
    throw std::runtime_error(
        "stop: only the client that started the run may stop it (e-stop works for anyone)");
  }
  // {"axis": NAME}: that axis alone (the board says when it is not in the run).
  json request = json::object();
  if (args.is_object() && args.contains(wire_key::axis))
    request[wire_key::axis] = args[wire_key::axis];
  return call("stop", request);
}

json BoardWatch::move_to(const json& args) {
  // Every argument the board declares, as the page sent it (the page builds
  // its form from the same dictionary); the lease is the config's when it
  // names one, else the board's.
  json request = args.is_object() ? args : json::object();
  if (!request.contains(wire_key::lease_s) && config_.host.board.lease_s > 0.0) {
    request[wire_key::lease_s] = config_.host.board.lease_s;
  }
  const std::lock_guard lock(commands_);
  if (const auto breach = protocol::check_arguments(dictionary_, "move_to", request)) {
    throw std::invalid_argument(fmt::format("{}: {}", breach->key, breach->message));
  }
  const json reply = client_.call("move_to", request);
  const auto started = protocol::decode<protocol::StartReply>(reply);
  lease_s_ = started.lease_s;
  last_lease_ = std::chrono::steady_clock::now();
  controlled_run_ = started.run;
  return reply;
}

}  // namespace piezo::host
