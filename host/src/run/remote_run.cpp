#include "remote_run.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <chrono>
#include <optional>
#include <zmq_addon.hpp>

#include "config_error.hpp"
#include "log_writer.hpp"
#include "piezo/protocol/frame.hpp"
#include "piezo/protocol/message.hpp"
#include "sample_collector.hpp"

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
constexpr std::uint64_t kFetchChunk = 50'000;

std::int64_t host_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(SteadyClock::now().time_since_epoch())
      .count();
}

hal::Status status_from(const std::string& name) {
  return hal::kStatusNames.parse(name).value_or(hal::Status::io_error);
}

LoopSummary loop_summary(const protocol::LoopHealth& h) {
  LoopSummary s;
  s.samples = h.cycles;
  s.overruns = h.overruns;
  s.missed_cycles = h.missed_cycles;
  s.dropped = h.dropped;
  s.errors = h.errors;
  if (h.timing) {
    s.p50_us = h.timing->p50_us;
    s.p99_us = h.timing->p99_us;
    s.max_us = h.timing->max_us;
    s.mean_us = h.timing->mean_us;
    s.histogram = h.timing->histogram_us;
  }
  return s;
}

/// Keeps each stream in sequence: frames that skip ahead have their gap
/// fetched from the recorder first; repeats are dropped.
class StreamCursor {
 public:
  StreamCursor(RigClient& client, SampleCollector& collector, std::vector<std::string>& gaps,
               std::function<double()> received_s)
      : client_(client), collector_(collector), gaps_(gaps), received_s_(std::move(received_s)) {}

  void on_frame(std::string_view frame) {
    const auto header = protocol::decode_header(frame);
    std::uint64_t& next = header.stream == protocol::Stream::drive ? drive_next_ : sensor_next_;
    if (header.first_seq > next) fetch(header.stream, header.first_seq);
    add(frame, header);
  }

  /// Fetches everything up to `end` not yet received, and notes the gap.
  void fetch(protocol::Stream stream, std::uint64_t end) {
    std::uint64_t& next = stream == protocol::Stream::drive ? drive_next_ : sensor_next_;
    if (next < end)
      gaps_.push_back(fmt::format("{} [{}, {})", protocol::to_string(stream), next, end));
    while (next < end) {
      const json r = client_.call("fetch",
                                  {{"stream", protocol::to_string(stream)},
                                   {"first", next},
                                   {"count", std::min(kFetchChunk, end - next)}},
                                  5s);
      const auto& bytes = r.at("frame").get_binary();
      const std::string frame(bytes.begin(), bytes.end());
      const auto header = protocol::decode_header(frame);
      if (header.count == 0) break;
      add(frame, header);
    }
  }

  [[nodiscard]] std::uint64_t drive_next() const { return drive_next_; }
  [[nodiscard]] std::uint64_t sensor_next() const { return sensor_next_; }

 private:
  void add(std::string_view frame, const protocol::FrameHeader& h) {
    std::uint64_t& next = h.stream == protocol::Stream::drive ? drive_next_ : sensor_next_;
    if (h.first_seq > next || h.first_seq + h.count <= next) return;  // a gap left, or a repeat
    const std::size_t skip = next - h.first_seq;
    collector_.set_received(received_s_());
    if (h.stream == protocol::Stream::drive) {
      const auto samples = protocol::decode_drive(frame);
      for (std::size_t i = skip; i < samples.size(); ++i) collector_.add(samples[i]);
    } else {
      const auto samples = protocol::decode_sensor(frame);
      for (std::size_t i = skip; i < samples.size(); ++i) collector_.add(samples[i]);
    }
    next = h.first_seq + h.count;
  }

  RigClient& client_;
  SampleCollector& collector_;
  std::vector<std::string>& gaps_;
  std::function<double()> received_s_;
  std::uint64_t drive_next_ = 0, sensor_next_ = 0;
};

}  // namespace

firmware::StopCause stop_cause_from(const std::string& name) {
  return firmware::kStopCauseNames.parse(name).value_or(firmware::StopCause::drive_fault);
}

namespace {

json configure_args(const config::RunConfig& c) {
  return protocol::ConfigureRequest{c.model.drive, c.run.duration_s};
}

/// The observer's model: the config's, with the parameters the board's
/// calibration fitted (its `model`) in their place; the log says which.
model::MotorParameters observer_model(const config::RunConfig& c, const protocol::Hello& hello,
                                      RunLog& log) {
  model::Parameters p{c.model.drive, c.model.motor};
  const json& cal = hello.calibration;
  if (!cal.is_object() || !cal.value("model", json()).is_object()) return p.motor;
  std::vector<std::string> used;
  const json parameters = cal.at("model").value("parameters", json::object());
  for (const auto& [name, value] : parameters.items()) {
    const model::ParameterSpec* spec = model::find_parameter(name);
    if (spec == nullptr || spec->section != "model" || !value.is_number() ||
        !spec->admits(value.get<double>())) {
      continue;
    }
    spec->ref(p) = value.get<double>();
    used.push_back(fmt::format("{} = {:.6g}", name, value.get<double>()));
  }
  if (!used.empty()) {
    log.set_attribute("observer_model",
                      fmt::format("the board's calibration of {}: {}",
                                  cal.value("created", std::string("?")), fmt::join(used, ", ")));
  }
  return p.motor;
}

/// `start`, or for `piezo step` the protocol's `step`: the board runs whole periods.
json start_remote(const config::RunConfig& c, RigClient& client, std::optional<double> lease) {
  if (c.run.move) {
    const auto& d = c.model.drive;
    const auto& m = *c.run.move;
    const protocol::MoveToRequest request{m.target_rad,
                                          m.tolerance_rad,
                                          m.settle_s,
                                          m.timeout_s,
                                          m.hold_s,
                                          m.protect,
                                          static_cast<std::uint64_t>(m.stall_steps),
                                          m.V0,
                                          m.f,
                                          d.C_dr,
                                          d.e_dr,
                                          lease};
    return client.call("move_to", request);
  }
  if (c.run.calibrate) {
    json args = json::object();
    if (c.run.calibrate->V0) args["V0"] = *c.run.calibrate->V0;
    if (lease) args["lease_s"] = *lease;
    return client.call("calibrate", args);
  }
  if (c.run.step_periods == 0) {
    return client.call("start", lease ? json{{"lease_s", *lease}} : json::object());
  }
  return client.call("step", protocol::StepRequest{c.run.step_periods, c.model.drive, lease});
}

}  // namespace

void configure_remote(const config::RunConfig& c, RigClient& client) {
  try {
    (void)client.call("configure", configure_args(c));
  } catch (const RemoteError& e) {
    const std::string key = e.key() == "duration_s" ? "run.duration_s" : "drive." + e.key();
    throw config::ConfigError("piezod at " + client.address(), key,
                              fmt::format("refused by the board ({}): {}", e.code(), e.what()));
  }
}

ClockMapping estimate_clock_offset(RigClient& client, int round_trips) {
  ClockMapping best{0, std::numeric_limits<std::int64_t>::max()};
  for (int i = 0; i < round_trips; ++i) {
    const std::int64_t sent = host_ns();
    const auto board = client.call("clock").at("board_ns").get<std::int64_t>();
    const std::int64_t received = host_ns();
    // The fastest round trip bounds the offset most tightly.
    if (received - sent < best.round_trip_ns) {
      best = {board - (sent + received) / 2, received - sent};
    }
  }
  return best;
}

RunSummary execute_remote_run(const config::RunConfig& c, RigClient& client,
                              const protocol::Hello& hello, RunLog& log,
                              const std::atomic<bool>& stop,
                              const std::function<void(const LiveStatus&)>& on_status,
                              std::optional<double> lease, const std::atomic<bool>* estop) {
  RunSummary summary;
  if (stop.load()) {
    // Stopped during set-up: the drive is never started.
    summary.cause = firmware::StopCause::interrupted;
    summary.output.zero_confirmed = true;
    summary.realtime_notes.push_back("stopped before the start");
    return summary;
  }
  const ClockMapping clock = estimate_clock_offset(client);
  log.set_attribute("board_clock_offset_ns", std::to_string(clock.offset_ns));
  log.set_attribute("board_clock_round_trip_ns", std::to_string(clock.round_trip_ns));
  client.subscribe({"drive", "sensor", "state", "health"});
  std::this_thread::sleep_for(100ms);  // let the subscription reach the board first

  const json started = start_remote(c, client, lease);
  const auto t0 = started.at("t0_ns").get<hal::TimeNs>();
  const auto run_id = started.at("run").get<std::uint64_t>();
  const double lease_s = started.at("lease_s").get<double>();
  log.set_attribute("board_t0_ns", std::to_string(t0));
  log.set_attribute("rig", client.address());

  std::optional<ObserverStage> observer;
  if (c.observer.enabled) {
    observer.emplace(observer_model(c, hello, log), c.observer.gains, 1.0 / hello.drive_rate_hz,
                     hello.output_latency_s);
  }
  // A move's angles are from the board's zero (the frame of its target and
  // of every position it reports); a run's from its first good reading.
  const json zero = started.value("zero_displacement_m", json());
  SampleCollector collector(
      t0, c.sensor.r2_m, observer ? &*observer : nullptr,
      zero.is_number() ? zero.get<double>() : std::numeric_limits<double>::quiet_NaN());
  if (zero.is_number()) {
    log.set_attribute("theta_zero_m",
                      fmt::format("{:.12g} (the board's zero)", zero.get<double>()));
  }
  std::vector<std::string> gaps;
  const std::int64_t host_start = host_ns();
  const bool virtual_clock = hello.clock == "virtual";
  StreamCursor cursor(client, collector, gaps, [&] {
    return virtual_clock ? 1e-9 * static_cast<double>(host_ns() - host_start)
                         : hal::to_seconds(host_ns() + clock.offset_ns - t0);
  });

  bool log_ok = true;
  bool stop_sent = false, estop_sent = false;
  // From here until writer.finish() only the writer's thread touches the log.
  LogWriter writer(log);
  auto append_log = [&] {
    if (!log_ok) return;
    writer.submit(collector.rows());
    if (std::string e = writer.error(); !e.empty()) {
      log_ok = false;
      summary.host_error = std::move(e);
    }
  };
  auto finish_writing = [&] {
    append_log();
    if (std::string e = writer.finish(); !e.empty() && log_ok) {
      log_ok = false;
      summary.host_error = std::move(e);
    }
  };
  const auto lease_period = std::chrono::duration<double>(lease_s / 4.0);
  const auto flush_interval = std::chrono::duration<double>(c.run.flush_interval_s);
  auto last_lease = SteadyClock::now(), last_flush = last_lease, last_status = last_lease,
       last_heard = last_lease;
  std::optional<protocol::RunSummary> final_summary;
  protocol::HealthEvent health;
  health.state = "running";  // until the board says otherwise
  // Spans with nothing heard from the board, on the board's run time.
  std::vector<std::string> outages;
  double quiet_since_s = std::nan("");  // NaN: heard recently
  const auto board_run_s = [&] {
    return virtual_clock ? collector.last_t() : hal::to_seconds(host_ns() + clock.offset_ns - t0);
  };
  auto last_contact = last_lease;
  while (!final_summary) {
    if (SteadyClock::now() - last_contact >= kBoardGone) break;
    if ((stop.load() || !log_ok) && !stop_sent) {
      try {
        (void)client.call("stop", json::object(), 1s);
        stop_sent = true;
      } catch (const LinkTimeout&) {
      }  // the lease stops the board by itself
    }
    if (estop != nullptr && estop->load() && !estop_sent) {
      try {
        (void)client.call("estop", json::object(), 1s);
        estop_sent = true;
      } catch (const LinkTimeout&) {
      }  // tried again on the next turn
    }
    const bool ready = poll_in(client.stream(), 5ms);
    // Frames are drained until the lease is due, never past it: with the
    // observer on, a virtual-clock board's backlog (up to 20 s of samples)
    // took the loop longer than a lease to work through, and the board
    // stopped a run the host was following with link_lost.
    for (int i = 0; i < 256 && ready && SteadyClock::now() - last_lease < lease_period; ++i) {
      std::vector<zmq::message_t> parts;
      if (!zmq::recv_multipart(client.stream(), std::back_inserter(parts),
                               zmq::recv_flags::dontwait) ||
          parts.size() != 2) {
        break;
      }
      last_heard = SteadyClock::now();
      if (!std::isnan(quiet_since_s)) {
        outages.push_back(fmt::format("[{:.3f}, {:.3f}] s", quiet_since_s, board_run_s()));
        quiet_since_s = std::nan("");
      }
      if (parts[0].to_string_view() == "health") {
        health = protocol::decode<protocol::HealthEvent>(
            protocol::decode_map(parts[1].to_string_view()));
      } else if (parts[0].to_string_view() == "state") {
        const auto state =
            protocol::decode<protocol::StateEvent>(protocol::decode_map(parts[1].to_string_view()));
        if (state.summary && state.run == run_id) final_summary = state.summary;
      } else {
        cursor.on_frame(parts[1].to_string_view());
        last_contact = last_heard;  // samples: the board is running this run
      }
    }
    const auto now = SteadyClock::now();
    if (now - last_lease >= lease_period) {
      // Acknowledged: what is logged, not only received (see LogWriter).
      // A failed log logs nothing more: everything received is acknowledged,
      // so a virtual-clock board does not wait on it.
      const std::uint64_t received = cursor.drive_next();
      const std::uint64_t unlogged =
          log_ok ? writer.pending_drive_rows() + collector.rows().drive.t.size() : 0;
      client.send("lease", {{"drive_received", received - std::min(received, unlogged)}});
      last_lease = now;
    }
    // The board is idle or faulted but its end-of-run event went unheard
    // (published while the link was down): ask for it.
    const bool board_done = health.state == "idle" || health.state == "fault";
    const bool quiet = now - last_heard >= kQuietBeforeAsking;
    if (board_done || quiet) {
      // Quiet stream: the link may be down, or the run's end went unheard.
      // Only silence is an outage: a board that looks done (the health
      // published before the start may still say idle) is just asked.
      if (quiet && std::isnan(quiet_since_s)) {
        quiet_since_s = board_run_s() - std::chrono::duration<double>(now - last_heard).count();
      }
      try {
        const json s = client.call("status", json::object(), 500ms);
        const json& run = s.value("run", json::object());
        // A board that restarted answers, but knows nothing of this run (its
        // ids start again: the start time tells): that is silence too.
        const bool ours =
            run.value("id", json()) == run_id && run.value("t0_ns", json()) == started.at("t0_ns");
        if (ours && run.value("finished", false)) {
          final_summary = protocol::decode<protocol::RunSummary>(run.at("summary"));
        }
        last_heard = SteadyClock::now();
        if (ours) last_contact = last_heard;
      } catch (const LinkTimeout&) {
        last_heard = SteadyClock::now();  // ZeroMQ reconnects with back-off; ask again later
      }
    }
    if (now - last_flush >= flush_interval) {
      append_log();
      last_flush = now;
    }
    if (on_status && now - last_status >= kStatusPeriod) {
      on_status({collector.last_t(), started.value("duration_s", c.run.duration_s),
                 collector.last_V(), collector.last_theta(),
                 observer ? observer->summary().last_residual_rad : 0.0, cursor.sensor_next(),
                 health.sensor ? health.sensor->errors : 0,
                 health.drive ? health.drive->overruns : 0, health,
                 json{{"drive", collector.drive_errors()}, {"sensor", collector.sensor_errors()}},
                 lease_s});
      last_status = now;
    }
  }
  if (!final_summary) {
    if (observer) observer->finish(collector.rows().observer);
    finish_writing();
    outages.push_back(fmt::format("[{:.3f}, end of run]", quiet_since_s));
    log.set_attribute("link_outages", fmt::format("{}", fmt::join(outages, "; ")));
    summary.cause = firmware::StopCause::link_lost;
    summary.board_gone = true;
    summary.host_error = fmt::format(
        "board {} silent about this run for {} s (gone, or restarted): the run's end is unknown "
        "(the board's lease stops its drive by itself); the log holds what was received",
        client.address(), std::chrono::duration_cast<std::chrono::seconds>(kBoardGone).count());
    summary.theta_end_rad = collector.last_theta();
    summary.t_end_s = collector.last_good_t();
    return summary;
  }
  const protocol::RunSummary& board = *final_summary;
  // The stream's tail may still be in flight or lost: the recorder has it all.
  cursor.fetch(protocol::Stream::drive, board.drive_samples);
  cursor.fetch(protocol::Stream::sensor, board.sensor_samples);
  if (observer) observer->finish(collector.rows().observer);
  finish_writing();
  if (!std::isnan(quiet_since_s)) {
    outages.push_back(fmt::format("[{:.3f}, end of run]", quiet_since_s));
  }
  log.set_attribute("link_outages",
                    outages.empty() ? "none" : fmt::format("{}", fmt::join(outages, "; ")));
  log.set_attribute("stream_gaps_fetched",
                    gaps.empty() ? "none" : fmt::format("{}", fmt::join(gaps, "; ")));

  summary.cause = stop_cause_from(board.cause);
  const auto& out = board.output;
  summary.output.enabled_ever = out.enabled_ever;
  summary.output.zero_confirmed = out.zero_confirmed;
  summary.output.zero_status = status_from(out.zero_status);
  summary.output.acknowledged_V = out.acknowledged_V.value_or(std::nan(""));
  summary.output.zero_writes = out.zero_writes;
  summary.output.enable_status = status_from(out.enable_status);
  summary.drive = loop_summary(board.drive);
  summary.sensor = loop_summary(board.sensor);
  summary.drive.errors_by_class = collector.drive_errors();
  summary.sensor.errors_by_class = collector.sensor_errors();
  if (observer) summary.observer = observer->summary();
  summary.theta_end_rad = collector.last_theta();
  summary.t_end_s = collector.last_good_t();
  summary.mean_velocity_rad_s =
      summary.t_end_s > 0.0 ? summary.theta_end_rad / summary.t_end_s : 0.0;
  summary.realtime_notes = board.realtime;
  if (!board.move.is_null()) summary.move = board.move;
  if (board.has_calibration) {
    summary.calibration = {
        {"calibration", board.calibration},
        {"error", board.calibration_error ? json(*board.calibration_error) : json(nullptr)}};
  }
  if (!client.address().starts_with("inproc://")) {
    summary.realtime_notes.push_back("board " + client.address());
  }
  return summary;
}

}  // namespace piezo::host
