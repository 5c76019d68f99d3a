#include "board_run.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <chrono>
#include <deque>
#include <optional>
#include <zmq_addon.hpp>

#include "io/log_schema.hpp"
#include "log_writer.hpp"
#include "piezo/firmware/wire_keys.hpp"
#include "piezo/protocol/frame.hpp"
#include "piezo/protocol/message.hpp"
#include "sample_collector.hpp"
#include "stream_follower.hpp"

namespace piezo::host {
namespace {

using nlohmann::json;
using SteadyClock = std::chrono::steady_clock;
using namespace std::chrono_literals;

constexpr auto kStatusPeriod = 200ms;
constexpr auto kQuietBeforeAsking = 500ms;  // no state event: ask for the status
// A board silent this long is gone (crashed, powered off, unplugged): its
// lease stopped its drive long ago, so the host ends the run as failed and
// keeps what it received, instead of waiting for an end it cannot hear.
constexpr auto kBoardGone = 10s;

std::int64_t host_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(SteadyClock::now().time_since_epoch())
      .count();
}

/// The observer's model of one axis: the config's (that axis's own in a
/// config of several), with the parameters the board's calibration of the
/// axis fitted (its `model`) in their place; the log says which.
model::MotorParameters observer_model(const config::ConfigFile& c, const protocol::AxisInfo& axis,
                                      RunLog& log, std::size_t log_axis) {
  // The config's own axis of that name (a config of one axis: its model is [model]'s).
  const config::AxisConfig* own = c.board.find_axis(axis.name);
  model::Parameters p = own != nullptr ? own->model : c.host.model;
  if (!axis.calibration || !axis.calibration->model.is_object()) return p.motor;
  const protocol::CalibrationRecord& cal = *axis.calibration;
  std::vector<std::string> used;
  // The fitted model as the host wrote it (calibration_report.cpp): its parameters' values.
  const json parameters = cal.model.value("parameters", json::object());
  for (const auto& [name, value] : parameters.items()) {
    const model::ParameterSpec* spec = model::find_parameter(name);
    if (spec == nullptr || spec->section != wire_key::model || !value.is_number() ||
        !spec->admits(value.get<double>())) {
      continue;
    }
    spec->ref(p) = value.get<double>();
    used.push_back(fmt::format("{} = {:.6g}", name, value.get<double>()));
  }
  if (!used.empty()) {
    log.set_axis_attribute(
        log_axis, log_schema::kObserverModel,
        fmt::format("the board's calibration of {}: {}", cal.created, fmt::join(used, ", ")));
  }
  return p.motor;
}

/// One axis of a run as the host follows it: its samples into its own
/// collector (its sensor's radius, its zero) and observer.
struct FollowedAxis {
  FollowedAxis(std::string axis_name, std::size_t index, hal::TimeNs t0, double r2,
               std::optional<ObserverStage> stage, double zero_m)
      : name(std::move(axis_name)),
        board_index(index),
        observer(std::move(stage)),
        collector(t0, r2, observer ? &*observer : nullptr, zero_m) {}
  // The collector points at this axis's observer: never copied or moved.
  FollowedAxis(const FollowedAxis&) = delete;
  FollowedAxis& operator=(const FollowedAxis&) = delete;
  std::string name;
  std::size_t board_index;
  std::optional<ObserverStage> observer;
  SampleCollector collector;
  std::vector<bool> logged_pulses;  ///< a scan's trigger pulses logged so far, by k

  /// A scan's pulse into the log's rows, once per k.
  void log_pulse(const protocol::TriggerPulse& p) {
    if (p.k >= logged_pulses.size()) logged_pulses.resize(p.k + 1, false);
    if (logged_pulses[p.k]) return;
    logged_pulses[p.k] = true;
    log_schema::TriggerRows& t = collector.rows().triggers;
    t.k.push_back(p.k);
    t.position_rad.push_back(p.position_rad);
    t.angle_rad.push_back(p.angle_rad);
    t.reading_s.push_back(p.reading_s);
    t.edge_s.push_back(p.edge_s);
    t.late.push_back(p.late ? 1.0 : 0.0);
  }
};

/// The axes a started run drives, in the log's order: a group move's
/// (`moves`), else the one the request named, else the board's one.
struct RunAxisStart {
  std::string name;
  std::optional<double> zero_m;  ///< a move's: the board's zero its target is from
};

std::vector<RunAxisStart> run_axes(const protocol::StartReply& started, const BoardRequest& request,
                                   const protocol::Hello& hello, const RunLog& log) {
  std::vector<RunAxisStart> out;
  if (started.moves) {
    for (const auto& m : *started.moves) out.push_back({m.axis, m.zero_displacement_m});
  } else if (started.scans) {
    for (const auto& s : *started.scans) out.push_back({s.axis, s.zero_displacement_m});
  } else {
    out.push_back({axis_info(hello, request.axis.value_or(""), "the board").name, {}});
  }
  // The log was made for the axes asked for: the board must have run those.
  std::vector<RunAxisStart> ordered;
  for (const std::string& name : log.axes()) {
    const auto it =
        std::find_if(out.begin(), out.end(), [&](const auto& a) { return a.name == name; });
    if (it == out.end()) {
      throw std::runtime_error(fmt::format("the board started no run of axis {}", name));
    }
    ordered.push_back(*it);
  }
  return ordered;
}

}  // namespace

ClockMapping estimate_clock_offset(BoardClient& client, int round_trips) {
  ClockMapping best{0, std::numeric_limits<std::int64_t>::max()};
  for (int i = 0; i < round_trips; ++i) {
    const std::int64_t sent = host_ns();
    const auto board = protocol::decode<protocol::ClockReply>(client.call("clock")).board_ns;
    const std::int64_t received = host_ns();
    // The fastest round trip bounds the offset most tightly.
    if (received - sent < best.round_trip_ns) {
      best = {board - (sent + received) / 2, received - sent};
    }
  }
  return best;
}

namespace {

/// A run on the board, followed by its controller: the stream into the log
/// (and the observer), the lease, stop and e-stop requests, the outages,
/// and the board's account of the run's end.
class FollowedRun {
 public:
  FollowedRun(const config::ConfigFile& c, BoardClient& client, const protocol::Hello& hello,
              RunLog& log, const protocol::StartReply& started, const ClockMapping& clock,
              std::deque<FollowedAxis>& axes,
              std::function<void(const log_schema::AxesRows&)> on_rows)
      : c_(c),
        client_(client),
        log_(log),
        started_(started),
        t0_(started.t0_ns),
        run_id_(started.run),
        lease_s_(started.lease_s),
        clock_(clock),
        virtual_clock_(hello.clock == "virtual"),
        axes_(axes),
        follower_(client,
                  [board = &client](const std::string& cmd, const json& args) {
                    return board->call(cmd, args, 5s);
                  }),
        writer_(log),
        on_rows_(std::move(on_rows)) {
    std::vector<SampleCollector*> by_axis(hello.axes.size());
    for (FollowedAxis& a : axes_) by_axis.at(a.board_index) = &a.collector;
    follower_.follow(std::move(by_axis), [this] {
      return virtual_clock_ ? 1e-9 * static_cast<double>(host_ns() - host_start_)
                            : hal::to_seconds(host_ns() + clock_.offset_ns - t0_);
    });
  }

  /// Follows until the board's account of the run's end, or until the
  /// board is gone (nullopt).
  std::optional<protocol::RunSummary> follow(
      const std::atomic<bool>& stop, const std::atomic<bool>* estop,
      const std::function<void(const LiveStatus&)>& on_status, AxisStops* axis_stops);
  /// The run's account from the board's summary; with none, a board gone.
  RunSummary finish(const std::optional<protocol::RunSummary>& board);
  /// The live status, every kStatusPeriod (`at_once`: now, the run's last).
  void report(const std::function<void(const LiveStatus&)>& on_status, bool at_once = false);

 private:
  /// Run time of the newest drive sample of any axis [s].
  [[nodiscard]] double last_t() const {
    double t = 0.0;
    for (const FollowedAxis& a : axes_) t = std::max(t, a.collector.last_t());
    return t;
  }
  [[nodiscard]] double board_run_s() const {
    return virtual_clock_ ? last_t() : hal::to_seconds(host_ns() + clock_.offset_ns - t0_);
  }
  void request_stops(const std::atomic<bool>& stop, const std::atomic<bool>* estop,
                     AxisStops* axis_stops);
  void drain(std::optional<protocol::RunSummary>& end);
  void renew_lease_if_due();
  void renew_lease();
  void ask_when_quiet(std::optional<protocol::RunSummary>& end);
  void append_log();
  void finish_writing();
  void note_outages();

  const config::ConfigFile& c_;
  BoardClient& client_;
  RunLog& log_;
  protocol::StartReply started_;
  hal::TimeNs t0_;
  std::uint64_t run_id_;
  double lease_s_;
  ClockMapping clock_;
  bool virtual_clock_;
  std::deque<FollowedAxis>& axes_;  ///< in the log's order
  std::int64_t host_start_ = host_ns();
  StreamFollower follower_;
  // From here until writer_.finish() only the writer's thread touches the log.
  LogWriter writer_;
  std::function<void(const log_schema::AxesRows&)> on_rows_;
  RunSummary summary_;
  bool log_ok_ = true, stop_sent_ = false, estop_sent_ = false;
  SteadyClock::time_point last_lease_ = SteadyClock::now(), last_flush_ = last_lease_,
                          last_status_ = last_lease_, last_contact_ = last_lease_;
  // Spans with nothing heard from the board, on the board's run time.
  std::vector<std::string> outages_;
  double quiet_since_s_ = std::nan("");  // NaN: heard recently
};

std::optional<protocol::RunSummary> FollowedRun::follow(
    const std::atomic<bool>& stop, const std::atomic<bool>* estop,
    const std::function<void(const LiveStatus&)>& on_status, AxisStops* axis_stops) {
  std::optional<protocol::RunSummary> end;
  while (!end) {
    if (SteadyClock::now() - last_contact_ >= kBoardGone) break;
    request_stops(stop, estop, axis_stops);
    drain(end);
    renew_lease_if_due();
    ask_when_quiet(end);
    if (SteadyClock::now() - last_flush_ >=
        std::chrono::duration<double>(c_.host.run.flush_interval_s)) {
      append_log();
      last_flush_ = SteadyClock::now();
    }
    report(on_status);
  }
  return end;
}

void FollowedRun::request_stops(const std::atomic<bool>& stop, const std::atomic<bool>* estop,
                                AxisStops* axis_stops) {
  // One axis's stop: that axis ramps down, the others go on. Sent once; a
  // lost one is the operator's to press again (the run's Stop and E-stop
  // stay).
  for (const std::string& axis : axis_stops ? axis_stops->take() : std::vector<std::string>{}) {
    try {
      (void)client_.call("stop", json{{wire_key::axis, axis}}, 1s);
    } catch (const std::exception&) {
    }
  }
  if ((stop.load() || !log_ok_) && !stop_sent_) {
    try {
      (void)client_.call("stop", json::object(), 1s);
      stop_sent_ = true;
    } catch (const LinkTimeout&) {
    }  // the lease stops the board by itself
  }
  if (estop != nullptr && estop->load() && !estop_sent_) {
    try {
      (void)client_.call("estop", json::object(), 1s);
      estop_sent_ = true;
    } catch (const LinkTimeout&) {
    }  // tried again on the next turn
  }
}

void FollowedRun::drain(std::optional<protocol::RunSummary>& end) {
  // Frames are drained until the lease is due, never past it: with the
  // observer on, a virtual-clock board's backlog (up to 20 s of samples)
  // took the loop longer than a lease to work through, and the board
  // stopped a run the host was following with link_lost.
  const auto lease_period = std::chrono::duration<double>(lease_s_ / 4.0);
  const std::uint64_t samples_before = follower_.drive_next() + follower_.sensor_next();
  StreamFollower::Handlers handlers;
  handlers.keep_going = [&] { return SteadyClock::now() - last_lease_ < lease_period; };
  handlers.on_heard = [&] {
    if (!std::isnan(quiet_since_s_)) {
      outages_.push_back(fmt::format("[{:.3f}, {:.3f}] s", quiet_since_s_, board_run_s()));
      quiet_since_s_ = std::nan("");
    }
  };
  handlers.on_state = [&](const protocol::StateEvent& state) {
    if (state.summary && state.run == run_id_) end = state.summary;
  };
  handlers.on_trigger = [&](const protocol::TriggerEvent& e) {
    if (e.run != run_id_) return;
    for (FollowedAxis& a : axes_)
      if (a.name == e.axis) a.log_pulse(e.pulse);
  };
  // The lease first, the gap after: a board that has heard no lease since
  // before an outage must not wait out the fetch of everything the outage
  // held back (seconds of samples, longer on a loaded machine).
  handlers.before_fetch = [&] { renew_lease(); };
  follower_.drain(5ms, 256, handlers);
  // Samples: the board is running this run.
  if (follower_.drive_next() + follower_.sensor_next() != samples_before) {
    last_contact_ = follower_.last_heard();
  }
}

void FollowedRun::renew_lease_if_due() {
  if (SteadyClock::now() - last_lease_ < std::chrono::duration<double>(lease_s_ / 4.0)) return;
  renew_lease();
}

void FollowedRun::renew_lease() {
  const auto now = SteadyClock::now();
  // Acknowledged: what is logged, not only received (see LogWriter). A
  // failed log logs nothing more: everything received is acknowledged, so
  // a virtual-clock board does not wait on it.
  const std::uint64_t received = follower_.drive_next();
  std::uint64_t unlogged = 0;
  if (log_ok_) {
    unlogged = writer_.pending_drive_rows();
    for (FollowedAxis& a : axes_) unlogged += a.collector.rows().drive.t.size();
  }
  client_.send("lease", protocol::LeaseRequest{received - std::min(received, unlogged)});
  last_lease_ = now;
}

void FollowedRun::ask_when_quiet(std::optional<protocol::RunSummary>& end) {
  // The board is idle or faulted but its end-of-run event went unheard
  // (published while the link was down): ask for it.
  const auto now = SteadyClock::now();
  const auto& state = follower_.health().state;
  const bool board_done =
      state == protocol::BoardState::idle || state == protocol::BoardState::fault;
  const bool quiet = now - follower_.last_heard() >= kQuietBeforeAsking;
  if (!board_done && !quiet) return;
  // Quiet stream: the link may be down, or the run's end went unheard. Only
  // silence is an outage: a board that looks done (the health published
  // before the start may still say idle) is just asked.
  if (quiet && std::isnan(quiet_since_s_)) {
    quiet_since_s_ =
        board_run_s() - std::chrono::duration<double>(now - follower_.last_heard()).count();
  }
  try {
    const auto s =
        protocol::decode<protocol::Status>(client_.call("status", json::object(), 500ms));
    // A board that restarted answers, but knows nothing of this run (its
    // ids start again: the start time tells): that is silence too.
    const bool ours = s.run && s.run->id == run_id_ && s.run->t0_ns == t0_;
    if (ours && s.run->finished) end = s.run->summary;
    follower_.heard();
    if (ours) last_contact_ = follower_.last_heard();
  } catch (const LinkTimeout&) {
    follower_.heard();  // ZeroMQ reconnects with back-off; ask again later
  }
}

void FollowedRun::append_log() {
  log_schema::AxesRows rows;
  for (FollowedAxis& a : axes_) rows.push_back(std::exchange(a.collector.rows(), {}));
  if (on_rows_) on_rows_(rows);
  if (!log_ok_) return;  // a failed log takes nothing more; the view had them
  writer_.submit(rows);
  if (std::string e = writer_.error(); !e.empty()) {
    log_ok_ = false;
    summary_.host_error = std::move(e);
  }
}

void FollowedRun::finish_writing() {
  for (FollowedAxis& a : axes_)
    if (a.observer) a.observer->finish(a.collector.rows().observer);
  append_log();
  if (std::string e = writer_.finish(); !e.empty() && log_ok_) {
    log_ok_ = false;
    summary_.host_error = std::move(e);
  }
}

void FollowedRun::report(const std::function<void(const LiveStatus&)>& on_status, bool at_once) {
  const auto now = SteadyClock::now();
  if (!on_status || (!at_once && now - last_status_ < kStatusPeriod)) return;
  const auto& health = follower_.health();
  const FollowedAxis& first = axes_.front();
  on_status({last_t(), started_.duration_s, first.collector.last_V(), first.collector.last_theta(),
             first.observer ? first.observer->summary().last_residual_rad : 0.0,
             follower_.sensor_next(), health.sensor ? health.sensor->errors : 0,
             health.drive ? health.drive->overruns : 0, health,
             json{{wire_key::drive, first.collector.drive_errors()},
                  {wire_key::sensor, first.collector.sensor_errors()}},
             lease_s_, log_ok_ ? std::string() : summary_.host_error});
  last_status_ = now;
}

RunSummary FollowedRun::finish(const std::optional<protocol::RunSummary>& end) {
  if (end) {
    // The stream's tail may still be in flight or lost: the recorder has it all.
    follower_.fetch(protocol::Stream::drive, end->samples.drive);
    follower_.fetch(protocol::Stream::sensor, end->samples.sensor);
    // So has the summary every pulse a scan fired: those the stream lost.
    for (const protocol::RunSummary::Axis& board_axis : end->axes) {
      if (!board_axis.scan || !board_axis.scan->pulses) continue;
      for (FollowedAxis& a : axes_) {
        if (a.name != board_axis.name) continue;
        for (const protocol::TriggerPulse& p : *board_axis.scan->pulses) a.log_pulse(p);
      }
    }
  }
  finish_writing();
  if (!std::isnan(quiet_since_s_) || !end) {
    outages_.push_back(fmt::format("[{:.3f}, end of run]", quiet_since_s_));
  }
  log_.set_attribute(log_schema::kLinkOutages,
                     outages_.empty() ? "none" : fmt::format("{}", fmt::join(outages_, "; ")));
  RunSummary& summary = summary_;
  for (const FollowedAxis& a : axes_) {
    AxisMeasured m;
    m.name = a.name;
    m.theta_end_rad = a.collector.last_theta();
    m.t_end_s = a.collector.last_good_t();
    m.drive_errors = a.collector.drive_errors();
    m.sensor_errors = a.collector.sensor_errors();
    if (a.observer) m.observer = a.observer->summary();
    m.mean_velocity_rad_s = m.t_end_s > 0.0 ? m.theta_end_rad / m.t_end_s : 0.0;
    summary.axes.push_back(std::move(m));
  }
  static_cast<AxisMeasured&>(summary) = summary.axes.front();
  if (!end) {
    summary.board.cause = firmware::StopCause::link_lost;
    summary.board_gone = true;
    summary.host_error = fmt::format(
        "board {} silent about this run for {} s (gone, or restarted): the run's end is unknown "
        "(the board's lease stops its drive by itself); the log holds what was received",
        client_.address(), std::chrono::duration_cast<std::chrono::seconds>(kBoardGone).count());
    return summary;
  }
  const auto& gaps = follower_.gaps();
  log_.set_attribute(log_schema::kStreamGapsFetched,
                     gaps.empty() ? "none" : fmt::format("{}", fmt::join(gaps, "; ")));
  summary.board = *end;
  if (!client_.address().starts_with("inproc://")) {
    summary.board.realtime.push_back("board " + client_.address());
  }
  return summary;
}

}  // namespace

RunSummary run_on_board(const config::ConfigFile& c, BoardClient& client,
                        const protocol::Hello& hello, RunLog& log, const std::atomic<bool>& stop,
                        const std::function<void(const LiveStatus&)>& on_status,
                        const BoardRequest& request, const std::atomic<bool>* estop,
                        const std::function<void(const log_schema::AxesRows&)>& on_rows,
                        AxisStops* axis_stops) {
  if (stop.load()) {
    // Stopped during set-up: the drive is never started.
    RunSummary summary;
    summary.board.cause = firmware::StopCause::interrupted;
    summary.board.output.zero_confirmed = true;  // never driven
    summary.board.realtime.push_back("stopped before the start");
    return summary;
  }
  const ClockMapping clock = estimate_clock_offset(client);
  log.set_attribute(log_schema::kBoardClockOffset, std::to_string(clock.offset_ns));
  log.set_attribute(log_schema::kBoardClockRoundTrip, std::to_string(clock.round_trip_ns));
  // Subscribed before the start, so that the run's first samples come.
  StreamFollower::subscribe(client);
  const auto started = protocol::decode<protocol::StartReply>(start_request(request, client));
  log.set_attribute(log_schema::kBoardT0, std::to_string(started.t0_ns));
  log.set_attribute(log_schema::kRig, client.address());
  std::deque<FollowedAxis> axes;
  const auto asked = run_axes(started, request, hello, log);
  for (std::size_t i = 0; i < asked.size(); ++i) {
    const RunAxisStart& a = asked[i];
    const protocol::AxisInfo& axis = axis_info(hello, a.name, client.address());
    std::optional<ObserverStage> observer;
    if (c.host.observer.enabled) {
      observer.emplace(observer_model(c, axis, log, i), c.host.observer.gains,
                       1.0 / hello.drive_rate_hz, hello.output_latency_s);
    }
    if (a.zero_m) {
      log.set_axis_attribute(i, log_schema::kThetaZero,
                             fmt::format("{:.12g} (the board's zero)", *a.zero_m));
    }
    // A move's and a scan's angles are from the board's zero (the frame of
    // its target and of every position it reports); a run's from its
    // first good reading.
    // The board's index of the axis (its records carry it).
    const auto index = static_cast<std::size_t>(&axis - hello.axes.data());
    axes.emplace_back(a.name, index, started.t0_ns, axis.r2_m, std::move(observer),
                      a.zero_m.value_or(std::numeric_limits<double>::quiet_NaN()));
  }
  FollowedRun run(c, client, hello, log, started, clock, axes, on_rows);
  const auto end = run.follow(stop, estop, on_status, axis_stops);
  RunSummary summary = run.finish(end);
  run.report(on_status, true);  // the end, and a log failed in its last flush, shown
  return summary;
}

}  // namespace piezo::host
