#include "daemon.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <filesystem>
#include <limits>
#include <zmq_addon.hpp>

#include "calibration.hpp"
#include "config_error.hpp"
#include "piezo/model/simulate.hpp"
#include "piezo/protocol/endpoints.hpp"
#include "piezo/protocol/frame.hpp"
#include "piezo/protocol/message.hpp"

namespace piezo::daemon {
namespace {

using nlohmann::json;
using protocol::ProtocolError;
namespace code = protocol::code;
using Clock = std::chrono::steady_clock;

constexpr std::size_t kMaxBatch = 2000;       // samples per published frame
constexpr std::uint64_t kMaxFetch = 100'000;  // samples per fetch reply
constexpr auto kPollPeriod = std::chrono::milliseconds(2);
constexpr auto kHealthPeriod = std::chrono::milliseconds(250);
// Samples published but not yet acknowledged by the controller's lease
// renewals hold the virtual clock back past this share of the recorder, or
// past this many seconds of drive samples: the host acknowledges what it
// has logged, so its memory holds at most that much not yet written.
constexpr double kVirtualAckWindow = 0.5;
constexpr double kVirtualAckWindow_s = 20.0;

json health_json(const firmware::LoopHealth& h) {
  json j{{"cycles", h.cycles.load()},
         {"overruns", h.overruns.load()},
         {"missed_cycles", h.missed_cycles.load()},
         {"dropped", h.dropped_samples.load()},
         {"errors", h.errors.load()}};
  return j;
}

/// The period-error statistics and histogram too (the histogram's counters
/// may be read while the loop runs).
json health_with_timing_json(const firmware::LoopHealth& h) {
  json j = health_json(h);
  j["p50_us"] = h.period_error.quantile_us(0.5);
  j["p99_us"] = h.period_error.quantile_us(0.99);
  j["max_us"] = h.period_error.max_us();
  j["mean_us"] = h.period_error.mean_us();
  const auto bins = h.period_error.bins();
  std::size_t used = bins.size();
  while (used > 0 && bins[used - 1] == 0) --used;
  j["histogram_us"] = std::vector<double>(bins.begin(), bins.begin() + static_cast<long>(used));
  return j;
}

bool latches(firmware::StopCause c) {
  return c != firmware::StopCause::completed && c != firmware::StopCause::interrupted &&
         c != firmware::StopCause::none;
}

/// Each command's arguments (docs/protocol.md, "Commands").
void refuse_unknown_args(const std::string& cmd, const json& args) {
  using protocol::refuse_unknown_args;
  if (cmd == "configure") {
    refuse_unknown_args(args, {"V0", "f", "C_dr", "e_dr", "direction", "duration_s"}, cmd);
  } else if (cmd == "start") {
    refuse_unknown_args(args, {"lease_s"}, cmd);
  } else if (cmd == "step") {
    refuse_unknown_args(args, {"count", "V0", "f", "C_dr", "e_dr", "direction", "lease_s"}, cmd);
  } else if (cmd == "move_to") {
    refuse_unknown_args(args,
                        {"target_rad", "tolerance_rad", "settle_s", "timeout_s", "V0", "f", "C_dr",
                         "e_dr", "lease_s", "protect", "stall_steps", "hold_s"},
                        cmd);
  } else if (cmd == "calibrate") {
    refuse_unknown_args(args, {"V0", "lease_s"}, cmd);
  } else if (cmd == "set_calibration") {
    refuse_unknown_args(args, {"calibration"}, cmd);
  } else if (cmd == "lease") {
    refuse_unknown_args(args, {"drive_received"}, cmd);
  } else if (cmd == "fetch") {
    refuse_unknown_args(args, {"stream", "first", "count"}, cmd);
  } else if (cmd == "hello" || cmd == "status" || cmd == "clock" || cmd == "zero" ||
             cmd == "stop" || cmd == "estop" || cmd == "reset_fault") {
    refuse_unknown_args(args, {}, cmd);
  }
}

ProtocolError out_of_limits(const std::string& key, const std::string& message) {
  return {code::out_of_limits, key, key + ": " + message};
}

}  // namespace

const char* to_string(State s) {
  switch (s) {
    case State::idle:
      return "idle";
    case State::running:
      return "running";
    case State::ramping_down:
      return "ramping_down";
    case State::fault:
      return "fault";
  }
  return "unknown";
}

struct Daemon::Run {
  std::uint64_t id = 0;
  RunRequest request;
  model::Sawtooth waveform;
  firmware::RemoteControl remote;
  std::unique_ptr<firmware::LoopRunner> runner;
  hal::TimeNs t0 = 0;
  double lease_s = 0.5;
  bool finished = false;
  json summary;                                    ///< once finished
  firmware::PositionFeed feed;                     ///< the acquire loop's readings, for a move
  std::unique_ptr<firmware::MoveController> move;  ///< a closed-loop move's program, if it is one
  std::unique_ptr<firmware::CalibrationProgram> calibration;  ///< the calibration's, if it is one
  std::unique_ptr<firmware::RunGuard> guard;  ///< a plain run's, with [safety] protect_runs
  bool move_takes_its_zero = false;           ///< the board had no zero when it began
  /// Measured after the run, at 0 V: the position a finished move reports
  /// (the controller's last reading came before the stop's ramp).
  std::optional<double> final_displacement_m;
  // The virtual clock's lease runs on wall time, checked by the network thread.
  std::atomic<std::int64_t> lease_renewed_ns{0};
  std::atomic<std::uint64_t> drive_acked{0}, drive_recorded{0};

  explicit Run(const RunRequest& r) : request(r), waveform(r.drive.V0, r.drive.f, r.drive.rise()) {}
};

Daemon::Daemon(const config::RunConfig& board, zmq::context_t& context, const std::string& listen,
               std::ostream& log)
    : Daemon(board, config::build_rig(board), context, listen, log) {}

Daemon::Daemon(const config::RunConfig& board, config::Rig rig, zmq::context_t& context,
               const std::string& listen, std::ostream& log)
    : board_(board),
      log_(log),
      rig_(std::move(rig)),
      context_(context),
      commands_(context, zmq::socket_type::router),
      stream_(context, zmq::socket_type::pub),
      command_endpoint_(listen.empty() ? board.daemon.listen : listen),
      drive_recorder_(static_cast<std::size_t>(board.daemon.recorder_s * board.drive.rate_hz)),
      sensor_recorder_(static_cast<std::size_t>(board.daemon.recorder_s * board.sensor.rate_hz())),
      fetch_budget_(board.daemon.fetch_samples_per_s, static_cast<double>(kMaxFetch)) {
  try {
    stream_endpoint_ = protocol::stream_endpoint(command_endpoint_);
  } catch (const std::invalid_argument& e) {
    throw config::ConfigError(listen.empty() ? board.source : "--listen", "piezod.listen",
                              e.what());
  }
  const bool network = protocol::is_network_endpoint(command_endpoint_);
  const auto& d = board_.daemon;
  if (network && d.secret_key_file.empty() && !d.insecure) {
    throw std::runtime_error(fmt::format(
        "listen = \"{}\" is a network address: set piezod.secret_key_file and "
        "piezod.authorized_keys_file (CURVE, keys from `piezod keygen`), or bind to 127.0.0.1; "
        "plain text on a network needs --insecure",
        command_endpoint_));
  }
  if (!d.secret_key_file.empty()) {
    const std::string secret = read_key(d.secret_key_file, "secret-key");
    if (d.authorized_keys_file.empty()) {
      throw std::runtime_error(
          "piezod.authorized_keys_file: missing (CURVE needs the clients' "
          "public keys)");
    }
    zap_ =
        std::make_unique<ZapHandler>(context_, read_authorized_keys(d.authorized_keys_file), log_);
    for (auto* s : {&commands_, &stream_}) {
      s->set(zmq::sockopt::curve_server, 1);
      s->set(zmq::sockopt::curve_secretkey, secret);
      s->set(zmq::sockopt::zap_domain, "piezod");
    }
    log_event("CURVE on: only authorized clients are admitted");
  } else if (network) {
    log_event("WARNING: --insecure: plain text on a network address, any peer may connect");
  }
  commands_.set(zmq::sockopt::router_mandatory, 0);
  // Larger than the largest command, so an oversized one is read and
  // answered too_large instead of costing its sender its connection and
  // the replies in flight on it.
  commands_.set(zmq::sockopt::maxmsgsize, static_cast<std::int64_t>(protocol::kMaxTransportBytes));
  commands_.set(zmq::sockopt::linger, 0);
  // Replies a client does not read wait in its queue up to this many; then
  // they are dropped, so one that never reads cannot fill the board's memory.
  commands_.set(zmq::sockopt::sndhwm, 64);
  stream_.set(zmq::sockopt::sndhwm, 100'000);
  stream_.set(zmq::sockopt::linger, 0);
  if (protocol::is_ipv6_endpoint(command_endpoint_)) {
    commands_.set(zmq::sockopt::ipv6, 1);
    stream_.set(zmq::sockopt::ipv6, 1);
  }
  try {
    commands_.bind(protocol::loopback_literal(command_endpoint_));
    stream_.bind(protocol::loopback_literal(stream_endpoint_));
  } catch (const zmq::error_t& e) {
    throw std::runtime_error(fmt::format("piezod.listen: cannot listen on {} / {}: {}",
                                         command_endpoint_, stream_endpoint_, e.what()));
  }
  if (!board_.daemon.spill_file.empty()) spill_.emplace(board_.daemon.spill_file);
  if (!board_.daemon.calibration_file.empty()) {
    // A file that cannot be used leaves the board uncalibrated (moves use
    // the model), said in the log; it is replaced by the next calibration.
    try {
      calibration_ = load_calibration(board_.daemon.calibration_file,
                                      {board_.drive.limits.V_max, board_.drive.rate_hz / 20.0});
      if (calibration_) {
        log_event(fmt::format("calibration of {} loaded from {}",
                              calibration_->at("created").get<std::string>(),
                              board_.daemon.calibration_file));
      }
    } catch (const std::exception& e) {
      log_event(fmt::format("calibration not loaded: {}", e.what()));
    }
  }
  last_health_ = Clock::now();
  log_event(fmt::format("listening: commands {}, stream {}; drive {}, sensor {}, lines {}",
                        command_endpoint_, stream_endpoint_, config::name(board_.drive.backend),
                        config::name(board_.sensor.backend), config::name(board_.lines.backend)));
}

Daemon::~Daemon() = default;

void Daemon::log_event(const std::string& line) {
  log_ << fmt::format("piezod [{:.6f}] {}\n", hal::to_seconds(rig_.clock->now()), line)
       << std::flush;
}

bool Daemon::running() const {
  return run_ && !run_->finished;
}

bool Daemon::drive_loop_progressing() {
  const auto now = Clock::now();
  const std::uint64_t cycles = running() ? run_->runner->drive_health().cycles.load() : 0;
  if (!running() || cycles != last_drive_cycles_ || board_.virtual_clock()) {
    last_drive_cycles_ = cycles;
    last_drive_progress_ = now;
    return true;
  }
  return now - last_drive_progress_ < std::chrono::seconds(1);
}

void Daemon::serve(const std::atomic<bool>& stop, const std::function<void()>& alive) {
  bool stopping = false;
  while (true) {
    if (stop.load() && !stopping) {
      stopping = true;
      if (running()) {
        log_event("shutting down: stopping the run first");
        run_->runner->request_stop();
      }
    }
    if (stopping && !running()) break;
    poll_once();
    if (alive && drive_loop_progressing()) alive();
  }
  log_event("stopped");
}

void Daemon::poll_once() {
  std::array<zmq::pollitem_t, 2> items{
      zmq::pollitem_t{commands_.handle(), 0, ZMQ_POLLIN, 0},
      zmq::pollitem_t{zap_ ? zap_->socket().handle() : nullptr, 0, ZMQ_POLLIN, 0}};
  try {
    zmq::poll(items.data(), zap_ ? 2 : 1, kPollPeriod);
  } catch (const zmq::error_t& e) {
    if (e.num() != EINTR) throw;
    return;  // a signal: serve() looks at the stop flag
  }
  if (zap_ && (items[1].revents & ZMQ_POLLIN) != 0) zap_->handle();
  if ((items[0].revents & ZMQ_POLLIN) != 0) {
    for (int i = 0; i < 64; ++i) {
      std::vector<zmq::message_t> frames;
      if (!zmq::recv_multipart(commands_, std::back_inserter(frames), zmq::recv_flags::dontwait)) {
        break;
      }
      on_command(frames);
    }
  }
  check_lease_on_wall_clock();
  pump_samples();
  if (run_ && !run_->finished && run_->runner->finished()) finish_run();
  if (Clock::now() - last_health_ >= kHealthPeriod) {
    publish_health();
    last_health_ = Clock::now();
  }
}

void Daemon::on_command(std::vector<zmq::message_t>& frames) {
  // [routing id, body] from a DEALER; [routing id, "", body] from a REQ.
  if (frames.size() < 2) return;
  const std::string client = frames.front().to_string();
  const bool req_envelope = frames.size() == 3 && frames[1].size() == 0;
  std::optional<std::uint64_t> id;
  std::string reply;
  try {
    if (frames.size() != (req_envelope ? 3u : 2u)) {
      throw ProtocolError(code::malformed, "", "a request is one frame");
    }
    const auto request = protocol::decode_request(frames.back().to_string_view(), id);
    reply = protocol::encode_reply(request.id, handle(client, request.cmd, request.args));
  } catch (const ProtocolError& e) {
    reply = protocol::encode_error(id, {e.code(), e.key(), e.what()});
  } catch (const std::exception& e) {
    // A failure of the daemon's own: the client hears it, the daemon goes on.
    reply = protocol::encode_error(id, {code::internal, "", e.what()});
    log_event(fmt::format("internal error: {}", e.what()));
  }
  std::vector<zmq::const_buffer> out{zmq::buffer(client)};
  if (req_envelope) out.push_back(zmq::str_buffer(""));
  out.push_back(zmq::buffer(reply));
  (void)zmq::send_multipart(commands_, out, zmq::send_flags::dontwait);
}

json Daemon::handle(const std::string& client, const std::string& cmd, const json& args) {
  refuse_unknown_args(cmd, args);
  if (cmd == "hello") return hello();
  if (cmd == "status") return status(client);
  if (cmd == "clock") return {{"board_ns", rig_.clock->now()}};
  if (cmd == "configure") return configure(client, args);
  if (cmd == "start") return start(client, args);
  if (cmd == "step") return step(client, args);
  if (cmd == "move_to") return move_to(client, args);
  if (cmd == "calibrate") return calibrate(client, args);
  if (cmd == "set_calibration") return set_calibration(client, args);
  if (cmd == "zero") return set_zero(client);
  if (cmd == "stop") return stop_run(client);
  if (cmd == "estop") return estop(client);
  if (cmd == "reset_fault") return reset_fault();
  if (cmd == "lease") return renew_lease(client, args);
  if (cmd == "fetch") return fetch(client, args);
  throw ProtocolError(code::unknown_command, "cmd",
                      fmt::format("cmd: \"{}\" is not a command (allowed: hello, status, clock, "
                                  "configure, start, step, move_to, calibrate, set_calibration, "
                                  "zero, stop, estop, reset_fault, lease, fetch)",
                                  cmd));
}

json Daemon::hello() const {
  const auto& lim = board_.drive.limits;
  return {{"protocol", protocol::kProtocolVersion},
          {"frame_version", protocol::kFrameVersion},
          {"daemon", PIEZO_VERSION},
          {"stream", stream_endpoint_},
          {"clock", config::name(board_.run.clock)},
          {"backends",
           {{"drive", config::name(board_.drive.backend)},
            {"sensor", config::name(board_.sensor.backend)},
            {"lines", config::name(board_.lines.backend)}}},
          {"limits",
           {{"V_min", lim.V_min},
            {"V_max", lim.V_max},
            {"slew_V_per_s", lim.slew_V_per_s},
            {"ramp_down_V_per_s", board_.safety.ramp_down_V_per_s},
            {"sensor_stale_s", board_.safety.sensor_stale_s},
            {"f_max_hz", board_.drive.rate_hz / 20.0},
            {"duration_max_s", board_.daemon.duration_max_s},
            {"lease_max_s", board_.daemon.lease_max_s}}},
          {"sensor", {{"r2_m", board_.sensor.r2_m}}},
          {"drive_rate_hz", board_.drive.rate_hz},
          {"sensor_rate_hz", board_.sensor.rate_hz()},
          {"output_latency_s", rig_.drive->output_latency_s()},
          {"lease_s", board_.daemon.lease_s},
          {"recorder_s", board_.daemon.recorder_s},
          {"calibration", calibration_ ? *calibration_ : json(nullptr)}};
}

json Daemon::status(const std::string& client) const {
  json j{
      {"state", to_string(state_)},
      {"board_ns", rig_.clock->now()},
      {"controller", !controller_.empty() && controller_ == client},
      {"controlled", !controller_.empty()},
      {"fault", state_ == State::fault ? json(firmware::to_string(fault_cause_)) : json(nullptr)},
      {"recorder",
       {{"drive", {{"first", drive_recorder_.first()}, {"next", drive_recorder_.next()}}},
        {"sensor", {{"first", sensor_recorder_.first()}, {"next", sensor_recorder_.next()}}}}},
      {"position", position_json()},
      {"calibration", calibration_ ? *calibration_ : json(nullptr)}};
  if (configured_) {
    j["configured"] = {{"V0", configured_->drive.V0},
                       {"f", configured_->drive.f},
                       {"C_dr", configured_->drive.C_dr},
                       {"e_dr", configured_->drive.e_dr},
                       {"direction", model::name(configured_->drive.direction)},
                       {"duration_s", configured_->duration_s}};
  }
  if (run_) {
    json r{{"id", run_->id},
           {"t0_ns", run_->t0},
           {"duration_s", run_->request.duration_s},
           {"lease_s", run_->lease_s},
           {"finished", run_->finished},
           {"drive", health_json(run_->runner->drive_health())},
           {"sensor", health_json(run_->runner->sensor_health())}};
    if (run_->finished) r["summary"] = run_->summary;
    if (run_->move) r["move"] = move_json(*run_);
    if (run_->calibration) r["calibration_progress"] = run_->calibration->progress();
    j["run"] = r;
  }
  return j;
}

json Daemon::configure(const std::string& client, const json& args, const char* cmd) {
  if (running()) require_controller(client, cmd);
  if (running())
    throw ProtocolError(code::bad_state, "", fmt::format("{}: a run is under way", cmd));
  RunRequest r;
  r.drive.V0 = protocol::number_arg(args, "V0");
  r.drive.f = protocol::number_arg(args, "f");
  r.drive.C_dr = protocol::number_arg(args, "C_dr", r.drive.C_dr);
  r.drive.e_dr = protocol::number_arg(args, "e_dr", r.drive.e_dr);
  r.duration_s = protocol::number_arg(args, "duration_s");
  const std::string direction = protocol::string_arg(args, "direction", "forward");
  if (const auto d = model::parse_direction(direction)) {
    r.drive.direction = *d;
  } else {
    throw ProtocolError(code::bad_argument, "direction",
                        fmt::format("direction: \"{}\"; allowed: forward, reverse", direction));
  }
  const auto& lim = board_.drive.limits;
  if (!(r.drive.V0 > 0.0 && r.drive.V0 <= lim.V_max && lim.V_min <= 0.0)) {
    throw out_of_limits(
        "V0", fmt::format("{:g} V is outside the board's limits; allowed: (0, {:g}] V", r.drive.V0,
                          lim.V_max));
  }
  const double f_max = board_.drive.rate_hz / 20.0;
  if (!(r.drive.f > 0.0 && r.drive.f <= f_max)) {
    throw out_of_limits("f", fmt::format("{:g} Hz gives under 20 drive samples per period at the "
                                         "board's {:g} Hz; allowed: (0, {:g}] Hz",
                                         r.drive.f, board_.drive.rate_hz, f_max));
  }
  if (!(r.drive.C_dr > 0.0 && r.drive.C_dr <= 1.0)) {
    throw out_of_limits("C_dr", fmt::format("{:g}; allowed: (0, 1]", r.drive.C_dr));
  }
  if (!(r.drive.e_dr >= 0.0 && r.drive.e_dr < 1.0)) {
    throw out_of_limits("e_dr", fmt::format("{:g}; allowed: [0, 1)", r.drive.e_dr));
  }
  const double D = r.drive.D();
  if (!(D > 0.0 && D < 1.0)) {
    throw out_of_limits("e_dr", fmt::format("with C_dr = {:g} the rise fraction D = {:g} is not "
                                            "inside (0, 1)",
                                            r.drive.C_dr, D));
  }
  const double fastest = r.drive.V0 * r.drive.f / std::min(D, 1.0 - D);
  if (fastest > lim.slew_V_per_s) {
    throw out_of_limits(
        "V0", fmt::format("the sawtooth's fastest edge, V0*f/min(D, 1-D) = {:.4g} V/s, exceeds "
                          "the board's slew limit {:g} V/s; allowed: V0*f <= {:.4g} V/s",
                          fastest, lim.slew_V_per_s, lim.slew_V_per_s * std::min(D, 1.0 - D)));
  }
  if (!(r.duration_s > 0.0 && r.duration_s <= board_.daemon.duration_max_s)) {
    throw out_of_limits("duration_s", fmt::format("{:g} s; allowed: (0, {:g}] s", r.duration_s,
                                                  board_.daemon.duration_max_s));
  }
  configured_ = r;
  return {
      {"V0", r.drive.V0},          {"f", r.drive.f}, {"C_dr", r.drive.C_dr},
      {"e_dr", r.drive.e_dr},      {"D", D},         {"direction", model::name(r.drive.direction)},
      {"duration_s", r.duration_s}};
}

void Daemon::require_controller(const std::string& client, const char* cmd) const {
  if (!controller_.empty() && controller_ != client) {
    throw ProtocolError(code::not_controller, "",
                        fmt::format("{}: another client controls the rig; watch the stream or "
                                    "ask status, or estop",
                                    cmd));
  }
}

void Daemon::require_can_start(const std::string& client, const char* cmd) const {
  if (state_ == State::fault) {
    throw ProtocolError(code::fault_latched, "",
                        fmt::format("{}: the fault {} is latched; send reset_fault first", cmd,
                                    firmware::to_string(fault_cause_)));
  }
  if (running()) {
    require_controller(client, cmd);
    throw ProtocolError(code::bad_state, "", fmt::format("{}: a run is under way", cmd));
  }
}

json Daemon::start(const std::string& client, const json& args, const Program& program,
                   const char* cmd) {
  require_can_start(client, cmd);
  if (!configured_) {
    throw ProtocolError(code::bad_state, "", fmt::format("{}: send configure first", cmd));
  }
  const double lease_s = protocol::number_arg(args, "lease_s", board_.daemon.lease_s);
  if (!(lease_s > 0.0 && lease_s <= board_.daemon.lease_max_s)) {
    throw out_of_limits(
        "lease_s", fmt::format("{:g} s; allowed: (0, {:g}] s", lease_s, board_.daemon.lease_max_s));
  }
  run_.reset();  // the last run's runner (joined) goes; its samples are overwritten below
  auto run = std::make_unique<Run>(*configured_);
  run->id = ++run_count_;
  run->lease_s = lease_s;
  drive_recorder_.clear();
  sensor_recorder_.clear();
  if (spill_) spill_->clear();
  drive_published_ = sensor_published_ = 0;
  const bool virtual_clock = board_.virtual_clock();
  firmware::LoopRunnerSettings settings{{board_.drive.rate_hz, run->request.duration_s,
                                         1.0 / run->request.drive.f, board_.drive.limits},
                                        board_.safety,
                                        board_.sensor.rate_hz(),
                                        !virtual_clock,
                                        board_.run.priority,
                                        board_.run.lock_memory};
  settings.r2_m = board_.sensor.r2_m;
  settings.zero_m = zero_displacement_m_.value_or(std::numeric_limits<double>::quiet_NaN());
  const firmware::LoopDevices devices{*rig_.clock, *rig_.drive, *rig_.sensor, *rig_.lines};
  if (program.move) {
    run->move = std::make_unique<firmware::MoveController>(*program.move, run->feed);
    run->runner = std::make_unique<firmware::LoopRunner>(settings, *run->move, devices,
                                                         &run->remote, &run->feed);
  } else if (program.calibration) {
    run->calibration =
        std::make_unique<firmware::CalibrationProgram>(*program.calibration, run->feed);
    run->runner = std::make_unique<firmware::LoopRunner>(settings, *run->calibration, devices,
                                                         &run->remote, &run->feed);
  } else if (board_.safety.protect_runs) {
    firmware::RunGuardSettings g;
    g.periods = board_.safety.stall_periods;
    g.f = run->request.drive.f;
    g.direction = run->request.drive.direction == model::Direction::forward ? 1.0 : -1.0;
    g.r2_m = board_.sensor.r2_m;
    const double rad_per_V = calibration_ ? calibration_->at("rad_per_V").get<double>()
                                          : board_.model.motor.d_e / board_.model.motor.r;
    g.stroke_rad = rad_per_V * run->request.drive.V0;
    // The noise at rest, measured now (a few readings before the drive
    // starts), or the calibration's if larger.
    const AtRest rest = read_at_rest(2 * kZeroReadings);
    g.noise_m = std::max(rest.good >= 4 ? rest.stddev_m : 0.0,
                         calibration_ ? calibration_->at("noise_m").get<double>() : 0.0);
    run->guard = std::make_unique<firmware::RunGuard>(run->waveform, g, run->feed);
    run->runner = std::make_unique<firmware::LoopRunner>(settings, *run->guard, devices,
                                                         &run->remote, &run->feed);
  } else {
    run->runner = std::make_unique<firmware::LoopRunner>(settings, run->waveform, devices,
                                                         &run->remote, &run->feed);
  }
  const auto now_ns = [] {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch())
        .count();
  };
  run->lease_renewed_ns = now_ns();
  std::function<bool()> lagging;
  if (virtual_clock) {
    // Time waits for a controller that is alive but behind.
    Run* r = run.get();
    const auto window = static_cast<std::uint64_t>(
        std::min(kVirtualAckWindow * static_cast<double>(drive_recorder_.capacity()),
                 kVirtualAckWindow_s * board_.drive.rate_hz));
    const auto lease_ns = static_cast<std::int64_t>(lease_s * 1e9);
    lagging = [r, window, lease_ns, now_ns] {
      return now_ns() - r->lease_renewed_ns.load() < lease_ns &&
             r->drive_recorded.load() > r->drive_acked.load() + window;
    };
  }
  // The lease counts from the time origin, fixed once the loops are set up:
  // the real-time set-up (mlockall, thread priorities) may take longer than
  // a lease on a slow board, and the client renews only once it has the
  // start's reply.
  Run* starting = run.get();
  run->t0 = run->runner->start(
      [this, starting, virtual_clock, lease_s, now_ns](hal::TimeNs t0) {
        rig_.start_at(t0);
        starting->lease_renewed_ns = now_ns();
        if (!virtual_clock) starting->remote.lease_deadline = t0 + hal::from_seconds(lease_s);
      },
      lagging);
  controller_ = client;
  run_ = std::move(run);
  state_ = State::running;
  log_event(fmt::format("run {} started: V0 {:g} V, f {:g} Hz, {:g} s, lease {:g} s", run_->id,
                        run_->request.drive.V0, run_->request.drive.f, run_->request.duration_s,
                        lease_s));
  publish_state();
  return {{"run", run_->id},
          {"t0_ns", run_->t0},
          {"lease_s", lease_s},
          {"duration_s", run_->request.duration_s}};
}

json Daemon::step(const std::string& client, const json& args) {
  // A step is a run of whole drive periods: each period ends at 0 V (after
  // the fast edge forward, the slow edge in reverse), so the run ends there
  // with nothing left to ramp and the rotor is not pulled back.
  require_can_start(client, "step");  // before configure: a refused step changes nothing
  const std::uint64_t count = protocol::uint_arg(args, "count");
  json configure_args = args;
  configure_args.erase("count");
  configure_args.erase("lease_s");
  const double f = protocol::number_arg(args, "f");
  const double max_count = std::floor(board_.daemon.duration_max_s * f);
  if (count < 1 || !(static_cast<double>(count) <= max_count)) {
    throw out_of_limits(
        "count", fmt::format("{} periods at {:g} Hz; allowed: [1, {:g}] (the "
                             "board's longest run, {:g} s)",
                             count, f, std::max(max_count, 0.0), board_.daemon.duration_max_s));
  }
  configure_args["duration_s"] = static_cast<double>(count) / f;
  const json configured = configure(client, configure_args, "step");
  json started =
      start(client, args.contains("lease_s") ? json{{"lease_s", args["lease_s"]}} : json::object(),
            Program{}, "step");
  started["count"] = count;
  started["direction"] = configured.at("direction");
  return started;
}

json Daemon::move_to(const std::string& client, const json& args) {
  require_can_start(client, "move_to");  // before configure: a refused move changes nothing
  firmware::MoveSettings m;
  m.target_rad = protocol::number_arg(args, "target_rad");
  m.tolerance_rad = protocol::number_arg(args, "tolerance_rad", m.tolerance_rad);
  m.settle_s = protocol::number_arg(args, "settle_s", m.settle_s);
  const double timeout_s = protocol::number_arg(args, "timeout_s", 30.0);
  m.protect = protocol::bool_arg(args, "protect", m.protect);
  const std::uint64_t stall_steps =
      protocol::uint_arg(args, "stall_steps", static_cast<std::uint64_t>(m.stall_steps));
  if (stall_steps < 1 || stall_steps > firmware::MoveSettings::kMaxStallSteps) {
    throw out_of_limits("stall_steps", fmt::format("{}; allowed: 1..{}", stall_steps,
                                                   firmware::MoveSettings::kMaxStallSteps));
  }
  m.stall_steps = static_cast<int>(stall_steps);
  if (!(std::abs(m.target_rad) <= 10.0)) {
    throw out_of_limits("target_rad",
                        fmt::format("{:g} rad; allowed: [-10, 10] rad", m.target_rad));
  }
  if (!(m.tolerance_rad > 0.0 && m.tolerance_rad <= 0.1)) {
    throw out_of_limits("tolerance_rad",
                        fmt::format("{:g} rad; allowed: (0, 0.1] rad", m.tolerance_rad));
  }
  if (!(m.settle_s >= 0.0 && m.settle_s <= 10.0)) {
    throw out_of_limits("settle_s", fmt::format("{:g} s; allowed: [0, 10] s", m.settle_s));
  }
  if (!(timeout_s > 0.0 && timeout_s <= board_.daemon.duration_max_s)) {
    throw out_of_limits("timeout_s", fmt::format("{:g} s; allowed: (0, {:g}] s", timeout_s,
                                                 board_.daemon.duration_max_s));
  }
  m.hold_s = protocol::number_arg(args, "hold_s", 0.0);
  if (!(m.hold_s >= 0.0 && m.hold_s < timeout_s)) {
    throw out_of_limits(
        "hold_s", fmt::format("{:g} s; allowed: [0, timeout_s = {:g}) s", m.hold_s, timeout_s));
  }
  // At rest before the move: the board's zero when it has none (the frame
  // of the target, and of the log's angles), and the sensor's noise when
  // no calibration gives it.
  const AtRest rest =
      !zero_displacement_m_ || !calibration_ ? read_at_rest(2 * kZeroReadings) : AtRest{};
  if (!zero_displacement_m_ && rest.good >= 4) {
    zero_displacement_m_ = rest.mean_m;
    log_event(fmt::format("zero set at {:.9g} m (the mean of {} readings at rest before a move)",
                          rest.mean_m, rest.good));
  }
  const std::optional<double> noise = calibration_
                                          ? std::optional(calibration_->at("noise_m").get<double>())
                                      : rest.good >= 4 ? std::optional(rest.stddev_m)
                                                       : std::nullopt;
  // A tolerance finer than the sensor resolves would never be reached.
  if (noise) {
    const double smallest = smallest_tolerance_rad(*noise, board_.sensor.r2_m);
    if (m.tolerance_rad < smallest) {
      throw out_of_limits(
          "tolerance_rad",
          fmt::format("{:g} rad is below what the sensor resolves: its noise is {:.3g} m "
                      "({:.3g} rad a reading, {} at rest); allowed: at least {:.3g} rad",
                      m.tolerance_rad, *noise, *noise / board_.sensor.r2_m,
                      calibration_ ? "calibrated" : "measured now", smallest));
    }
  }
  // The coarse steps' waveform: the caller's, or the calibration's fastest
  // frequency, or the board's [drive] values.
  const auto& d0 = board_.model.drive;
  const double V0 = protocol::number_arg(args, "V0", d0.V0);
  const std::optional<double> f_asked =
      args.contains("f") ? std::optional(protocol::number_arg(args, "f")) : std::nullopt;
  double f = f_asked.value_or(d0.f);
  if (!f_asked && calibration_ && calibration_->at("fastest_f_hz").is_number() &&
      std::abs(calibration_->at("V0").get<double>() - V0) <= 1e-9 * V0) {
    f = calibration_->at("fastest_f_hz").get<double>();
  }
  const json configure_args{{"V0", V0},
                            {"f", f},
                            {"C_dr", protocol::number_arg(args, "C_dr", d0.C_dr)},
                            {"e_dr", protocol::number_arg(args, "e_dr", d0.e_dr)},
                            {"duration_s", timeout_s}};
  (void)configure(client, configure_args, "move_to");
  const auto& d = configured_->drive;
  const auto& motor = board_.model.motor;
  m.zero_displacement_m = zero_displacement_m_.value_or(std::numeric_limits<double>::quiet_NaN());
  const bool zero_before = zero_displacement_m_.has_value();
  m.r2_m = board_.sensor.r2_m;
  m.V0 = d.V0;
  m.f = d.f;
  m.D = d.D();
  // The model's (or a fitted config's) view of the motor: what one step
  // gives at V0 each way, and the angle per volt while the rotor sticks.
  m.rad_per_V = motor.d_e / motor.r;
  const double T = 1.0 / d.f;
  for (std::size_t i = 0; i < firmware::MoveSettings::kStepFractions.size(); ++i) {
    // One period from rest at each amplitude, each way. A prediction of
    // (almost) nothing still gets a try: the measured steps correct it.
    const double V = firmware::MoveSettings::kStepFractions[i] * d.V0;
    const double floor = 1e-3 * m.rad_per_V * V;
    m.step_forward_rad[i] = std::max(
        floor,
        model::final_angle(motor, model::Sawtooth(V, d.f, d.D()), model::FrictionModel::lugre, T));
    m.step_reverse_rad[i] =
        std::max(floor, -model::final_angle(motor, model::Sawtooth(V, d.f, 1.0 - d.D()),
                                            model::FrictionModel::lugre, T));
  }
  m.fine_V_max = 0.8 * board_.drive.limits.V_max;
  m.fast_slew_V_per_s = board_.drive.limits.slew_V_per_s;
  const bool calibrated = calibration_ && apply_calibration(*calibration_, f_asked, m);
  if (!calibrated && !f_asked) {
    // Uncalibrated: twice and four times the frequency, as the model
    // predicts them, for when the steps come out far smaller than predicted.
    const double slew_f_max =
        board_.drive.limits.slew_V_per_s * std::min(d.D(), 1.0 - d.D()) / d.V0;
    for (const double factor : {2.0, 4.0}) {
      const double fa = factor * d.f;
      if (fa > board_.drive.rate_hz / 20.0 || fa > slew_f_max) break;
      auto& a = m.alternatives[static_cast<std::size_t>(m.alternative_count++)];
      a.f = fa;
      for (std::size_t i = 0; i < firmware::MoveSettings::kStepFractions.size(); ++i) {
        const double V = firmware::MoveSettings::kStepFractions[i] * d.V0;
        const double floor = 1e-3 * m.rad_per_V * V;
        a.forward_rad[i] =
            std::max(floor, model::final_angle(motor, model::Sawtooth(V, fa, d.D()),
                                               model::FrictionModel::lugre, 1.0 / fa));
        a.reverse_rad[i] =
            std::max(floor, -model::final_angle(motor, model::Sawtooth(V, fa, 1.0 - d.D()),
                                                model::FrictionModel::lugre, 1.0 / fa));
      }
    }
  }
  json started =
      start(client, args.contains("lease_s") ? json{{"lease_s", args["lease_s"]}} : json::object(),
            {m, std::nullopt}, "move_to");
  started["target_rad"] = m.target_rad;
  started["tolerance_rad"] = m.tolerance_rad;
  started["settle_s"] = m.settle_s;
  started["timeout_s"] = timeout_s;
  started["protect"] = m.protect;
  started["stall_steps"] = m.stall_steps;
  started["hold_s"] = m.hold_s;
  started["zero_displacement_m"] = zero_before ? json(m.zero_displacement_m) : json(nullptr);
  started["calibrated"] = calibrated;
  for (const char* key : {"V0", "f", "C_dr", "e_dr"}) started[key] = configure_args.at(key);
  run_->move_takes_its_zero = !zero_before;
  return started;
}

json Daemon::calibrate(const std::string& client, const json& args) {
  require_can_start(client, "calibrate");  // before configure: a refused one changes nothing
  const auto& lim = board_.drive.limits;
  const auto& d0 = board_.model.drive;
  firmware::CalibrationPlan plan;
  plan.V0 = protocol::number_arg(args, "V0", std::min(d0.V0, lim.V_max));
  plan.D = d0.D();
  plan.r2_m = board_.sensor.r2_m;
  plan.hold_V_max = 0.8 * lim.V_max;
  plan.fast_slew_V_per_s = lim.slew_V_per_s;
  plan.flush_readings = std::max(10, static_cast<int>(std::ceil(0.1 * board_.sensor.rate_hz())));
  // The board's frequency, twice and four times it: as many as the board's
  // rate and slew limit allow at V0.
  const double f_max = std::min(board_.drive.rate_hz / 20.0,
                                lim.slew_V_per_s * std::min(plan.D, 1.0 - plan.D) / plan.V0);
  plan.frequencies = 0;
  for (const double factor : {1.0, 2.0, 4.0}) {
    if (factor * d0.f > f_max) break;
    plan.f_hz[static_cast<std::size_t>(plan.frequencies++)] = factor * d0.f;
  }
  if (plan.frequencies == 0) {
    throw out_of_limits("V0", fmt::format("at {:g} V the board's frequency {:g} Hz exceeds its "
                                          "slew limit; allowed: a lower V0",
                                          plan.V0, d0.f));
  }
  const double duration_s = 1.5 * plan.duration_s(board_.sensor.rate_hz()) + 1.0;
  (void)configure(client,
                  {{"V0", plan.V0},
                   {"f", plan.f_hz[static_cast<std::size_t>(plan.frequencies - 1)]},
                   {"C_dr", d0.C_dr},
                   {"e_dr", d0.e_dr},
                   {"duration_s", duration_s}},
                  "calibrate");
  json started =
      start(client, args.contains("lease_s") ? json{{"lease_s", args["lease_s"]}} : json::object(),
            {std::nullopt, plan}, "calibrate");
  started["V0"] = plan.V0;
  started["f_hz"] = std::vector<double>(plan.f_hz.begin(), plan.f_hz.begin() + plan.frequencies);
  started["steps_per_point"] = plan.steps;
  return started;
}

json Daemon::set_calibration(const std::string& client, const json& args) {
  if (running()) {
    require_controller(client, "set_calibration");
    throw ProtocolError(code::bad_state, "", "set_calibration: a run is under way");
  }
  if (!args.contains("calibration")) {
    throw ProtocolError(code::bad_argument, "calibration",
                        "calibration: missing (a calibration map, or nil to clear it)");
  }
  const json& given = args.at("calibration");
  if (given.is_null()) {
    calibration_.reset();
    if (!board_.daemon.calibration_file.empty()) {
      std::error_code ignored;
      std::filesystem::remove(board_.daemon.calibration_file, ignored);
    }
    log_event("calibration cleared");
    return {{"calibration", nullptr}};
  }
  install_calibration(
      checked_calibration(given, {board_.drive.limits.V_max, board_.drive.rate_hz / 20.0}));
  return {{"calibration", *calibration_}};
}

void Daemon::install_calibration(json c) {
  calibration_ = std::move(c);
  std::string kept = "in memory only (no piezod.calibration_file)";
  if (!board_.daemon.calibration_file.empty()) {
    try {
      save_calibration(board_.daemon.calibration_file, *calibration_);
      kept = "kept in " + board_.daemon.calibration_file;
    } catch (const std::exception& e) {
      kept = fmt::format("NOT kept: {}", e.what());
    }
  }
  const json& fastest = calibration_->at("fastest_f_hz");
  log_event(fmt::format(
      "calibration installed: fastest reliable {}, noise {:.3g} m; {}",
      fastest.is_number() ? fmt::format("{:g} Hz", fastest.get<double>()) : std::string("none"),
      calibration_->at("noise_m").get<double>(), kept));
}

std::optional<double> Daemon::read_at_rest() {
  const AtRest r = read_at_rest(kZeroReadings);
  if (r.good == 0) return std::nullopt;
  return r.mean_m;
}

Daemon::AtRest Daemon::read_at_rest(std::size_t n) {
  hal::Clock& clock = *rig_.clock;
  clock.add_sleeper();  // the virtual clock schedules the threads it knows of
  const hal::TimeNs period = hal::from_seconds(1.0 / board_.sensor.rate_hz());
  hal::TimeNs next = clock.now();
  std::vector<double> readings;
  // The first readings after an idle gap may be the sensor's last ones
  // from before it (a simulated sensor's, measured 37 um off after a run of
  // steps): skipped.
  constexpr std::size_t kSkipped = 2;
  for (std::size_t i = 0; i < n + kSkipped; ++i, next += period) {
    clock.sleep_until(next);
    // 0 V again (the output holds it anyway, the amplifier is off): a
    // simulated plant advances only at a write, so the reading sees the
    // rotor at its time, not extrapolated from the stop.
    (void)rig_.drive->write(0.0);
    const hal::DisplacementReading r = rig_.sensor->read();
    if (i < kSkipped || r.status != hal::Status::ok || !std::isfinite(r.displacement_m)) continue;
    readings.push_back(r.displacement_m);
    recent_readings_.push_back(r.displacement_m);
    if (recent_readings_.size() > kZeroReadings) recent_readings_.pop_front();
  }
  clock.remove_sleeper();
  AtRest r;
  r.good = static_cast<int>(readings.size());
  if (readings.empty()) return r;
  double sum = 0.0;
  for (const double d : readings) sum += d;
  r.mean_m = sum / static_cast<double>(readings.size());
  if (readings.size() > 2) {
    // The noise from successive differences, by their median: a rotor
    // still creeping or one odd reading does not pass for noise.
    std::vector<double> steps;
    for (std::size_t i = 1; i < readings.size(); ++i) {
      steps.push_back(std::abs(readings[i] - readings[i - 1]));
    }
    std::nth_element(steps.begin(), steps.begin() + static_cast<long>(steps.size() / 2),
                     steps.end());
    // For Gaussian noise the difference of two readings has sigma*sqrt(2),
    // and its absolute value's median is 0.6745 of that.
    r.stddev_m = steps[steps.size() / 2] / (0.6745 * std::sqrt(2.0));
  }
  return r;
}

std::optional<double> Daemon::recent_displacement_m() const {
  if (recent_readings_.empty()) return std::nullopt;
  double sum = 0.0;
  for (double d : recent_readings_) sum += d;
  return sum / static_cast<double>(recent_readings_.size());
}

json Daemon::set_zero(const std::string& client) {
  // The frame of a run's target (a move's) must not shift under it: the
  // zero is the controller's between runs, and nobody's during one.
  if (running()) {
    require_controller(client, "zero");
    throw ProtocolError(code::bad_state, "", "zero: a run is under way; zero after it ends");
  }
  const auto last = recent_displacement_m();
  if (!last) {
    throw ProtocolError(code::bad_state, "",
                        "zero: no sensor reading yet; the zero is the first reading of the "
                        "next run or move until then");
  }
  zero_displacement_m_ = last;
  zero_readings_.clear();
  log_event(fmt::format("zero set at {:.9g} m", *zero_displacement_m_));
  return {{"position", position_json()}};
}

json Daemon::position_json() const {
  const auto last = recent_displacement_m();
  const bool known = zero_displacement_m_ && last;
  return {
      {"position_rad",
       known ? json((*last - *zero_displacement_m_) / board_.sensor.r2_m) : json(nullptr)},
      {"zero_displacement_m", zero_displacement_m_ ? json(*zero_displacement_m_) : json(nullptr)}};
}

json Daemon::move_json(const Run& run) const {
  const firmware::MoveController& m = *run.move;
  const double zero = m.zero_displacement_m();
  // On target, the settle's mean (read at 0 V, of as many readings as the
  // noise asks for); any other end, the readings taken after the stop.
  const bool settled = m.state() == firmware::MoveState::on_target;
  const double position = !settled && run.final_displacement_m && !std::isnan(zero)
                              ? (*run.final_displacement_m - zero) / m.settings().r2_m
                              : m.position_rad();
  const bool on_target = m.state() == firmware::MoveState::on_target;
  json j{{"state", firmware::to_string(m.state())},
         {"target_rad", m.settings().target_rad},
         {"tolerance_rad", m.settings().tolerance_rad},
         {"position_rad", std::isnan(position) ? json(nullptr) : json(position)},
         {"error_rad",
          std::isnan(position) ? json(nullptr) : json(m.settings().target_rad - position)},
         {"on_target", on_target},
         {"on_target_at_s", on_target ? json(m.on_target_at_s()) : json(nullptr)},
         {"steps", m.steps()},
         {"f_hz", m.f_hz()},
         {"noise_m", std::isnan(m.noise_m()) ? json(nullptr) : json(m.noise_m())}};
  if (m.settings().hold_s > 0.0) {
    const double rms = m.hold_rms_error_rad(), max = m.hold_max_error_rad();
    j["hold_s"] = m.settings().hold_s;
    j["hold_rms_error_rad"] = std::isnan(rms) ? json(nullptr) : json(rms);
    j["hold_max_error_rad"] = std::isnan(max) ? json(nullptr) : json(max);
  }
  if (run.finished) {
    const auto cause = run.runner->cause();
    j["stop_cause"] = on_target ? std::string("on_target")
                      : cause == firmware::StopCause::completed
                          ? std::string("timeout")
                          : std::string(firmware::to_string(cause));
  }
  return j;
}

json Daemon::stop_run(const std::string& client) {
  if (!running()) return {{"state", to_string(state_)}};
  require_controller(client, "stop");
  run_->runner->request_stop();
  log_event(fmt::format("run {}: stop requested", run_->id));
  return {{"state", to_string(state_)}};
}

json Daemon::estop(const std::string& client) {
  // Anyone may press it: it only ever makes the rig safer. The enable line
  // drops from this thread at once, where the backend has one, even while
  // the drive loop is blocked in a slow write; the loop then stops itself.
  if (running()) {
    run_->remote.estop.store(true);
    (void)rig_.lines->trip();
  } else {
    state_ = State::fault;
    fault_cause_ = firmware::StopCause::estop;
    publish_state();
  }
  log_event(
      fmt::format("e-stop from a client{}", controller_ == client ? " (the controller)" : ""));
  return {{"state", to_string(state_)}};
}

json Daemon::reset_fault() {
  if (running()) throw ProtocolError(code::bad_state, "", "reset_fault: a run is under way");
  if (state_ == State::fault) {
    log_event(fmt::format("fault {} reset", firmware::to_string(fault_cause_)));
    state_ = State::idle;
    fault_cause_ = firmware::StopCause::none;
    publish_state();
  }
  return {{"state", to_string(state_)}};
}

json Daemon::renew_lease(const std::string& client, const json& args) {
  if (!running()) throw ProtocolError(code::bad_state, "", "lease: no run is under way");
  if (controller_ != client) {
    throw ProtocolError(code::not_controller, "", "lease: only the controlling client renews it");
  }
  if (args.contains("drive_received")) {
    run_->drive_acked = protocol::uint_arg(args, "drive_received");
  }
  if (board_.virtual_clock()) {
    run_->lease_renewed_ns =
        std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch())
            .count();
  } else {
    run_->remote.lease_deadline = rig_.clock->now() + hal::from_seconds(run_->lease_s);
  }
  return {{"lease_s", run_->lease_s}};
}

void Daemon::check_lease_on_wall_clock() {
  if (!running() || !board_.virtual_clock()) return;
  const auto now =
      std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
  if (static_cast<double>(now - run_->lease_renewed_ns.load()) > run_->lease_s * 1e9) {
    // Expire it on the board clock, as of now: the drive loop stops with
    // link_lost (unless the run's duration had already ended by then).
    run_->remote.lease_deadline.store(
        std::min(run_->remote.lease_deadline.load(), rig_.clock->now()));
  }
}

json Daemon::fetch(const std::string& client, const json& args) {
  const auto stream = protocol::stream_from_string(protocol::string_arg(args, "stream"), "stream");
  const std::uint64_t first = protocol::uint_arg(args, "first");
  const std::uint64_t count = protocol::uint_arg(args, "count");
  if (count > kMaxFetch) {
    throw out_of_limits("count",
                        fmt::format("{}; allowed: at most {} per fetch", count, kMaxFetch));
  }
  // Budgeted while a run is under way, for everyone but its controller
  // (whose gap filling its own lease waits on): a watcher's fetches cost
  // the run a bounded amount.
  if (const double wait_s = running() && client != controller_
                                ? fetch_budget_.take(client, static_cast<double>(count))
                                : 0.0;
      wait_s > 0) {
    throw ProtocolError(code::rate_limited, "count",
                        fmt::format("fetch: over this client's budget of {:g} samples/s; "
                                    "retry in {:.3f} s",
                                    fetch_budget_.samples_per_s(), wait_s));
  }
  if (spill_) {
    const auto held =
        stream == protocol::Stream::drive ? drive_recorder_.first() : sensor_recorder_.first();
    if (first < held) {
      // Past the memory ring: the spill file has it.
      if (auto frame = spill_->fetch(stream, first, count)) {
        return {{"frame", json::binary(std::vector<std::uint8_t>(frame->begin(), frame->end()))}};
      }
    }
  }
  const auto check = [&](std::uint64_t held_first, std::uint64_t held_next) {
    if (first < held_first || first > held_next) {
      throw ProtocolError(code::not_available, "first",
                          fmt::format("first: {} is not recorded; the recorder holds [{}, {})",
                                      first, held_first, held_next));
    }
  };
  std::string frame;
  if (stream == protocol::Stream::drive) {
    check(drive_recorder_.first(), drive_recorder_.next());
    std::vector<firmware::DriveSample> samples;
    drive_recorder_.copy(first, count, samples);
    frame = protocol::encode_frame(first, samples);
  } else {
    check(sensor_recorder_.first(), sensor_recorder_.next());
    std::vector<firmware::SensorSample> samples;
    sensor_recorder_.copy(first, count, samples);
    frame = protocol::encode_frame(first, samples);
  }
  return {{"frame", json::binary(std::vector<std::uint8_t>(frame.begin(), frame.end()))}};
}

void Daemon::pump_samples() {
  if (!run_) return;
  bool ramping = false;
  run_->runner->drain(
      [&](const firmware::DriveSample& s) {
        drive_recorder_.push(s);
        ramping = ramping || s.phase == firmware::DrivePhase::ramping_down;
      },
      [this](const firmware::SensorSample& s) {
        sensor_recorder_.push(s);
        if (s.status != hal::Status::ok) return;
        recent_readings_.push_back(s.displacement_m);
        if (recent_readings_.size() > kZeroReadings) recent_readings_.pop_front();
        // No zero yet: the mean of the first readings (as a move takes it).
        if (!zero_displacement_m_ && zero_readings_.size() < kZeroReadings) {
          zero_readings_.push_back(s.displacement_m);
          if (zero_readings_.size() == kZeroReadings) {
            double sum = 0.0;
            for (double d : zero_readings_) sum += d;
            zero_displacement_m_ = sum / static_cast<double>(kZeroReadings);
          }
        }
      });
  run_->drive_recorded = drive_recorder_.next();
  // The drive's own phase says when the stop began.
  if (ramping && state_ == State::running) {
    state_ = State::ramping_down;
    publish_state();
  }
  const auto publish = [this](const char* topic, auto& recorder, std::uint64_t& published) {
    using Sample = typename std::decay_t<decltype(recorder)>::value_type;
    std::vector<Sample> batch;
    while (published < recorder.next()) {
      published = std::max(published, recorder.first());
      recorder.copy(published, kMaxBatch, batch);
      if (batch.empty()) break;
      const std::string frame = protocol::encode_frame(published, batch);
      if (spill_) spill_->append(frame);
      std::array<zmq::const_buffer, 2> parts{zmq::buffer(std::string_view(topic)),
                                             zmq::buffer(frame)};
      (void)zmq::send_multipart(stream_, parts, zmq::send_flags::dontwait);
      published += batch.size();
    }
  };
  publish("drive", drive_recorder_, drive_published_);
  publish("sensor", sensor_recorder_, sensor_published_);
}

void Daemon::finish_run() {
  auto& run = *run_;
  run.runner->join();
  pump_samples();
  if (run.move) run.final_displacement_m = read_at_rest();
  if (run.calibration) run.final_displacement_m = read_at_rest();
  run.finished = true;
  const auto cause = run.runner->cause();
  const auto& out = run.runner->outcome();
  run.summary = {
      {"cause", firmware::to_string(cause)},
      {"output",
       {{"state", firmware::output_state(out)},
        {"zero_confirmed", out.zero_confirmed},
        {"acknowledged_V",
         std::isnan(out.acknowledged_V) ? json(nullptr) : json(out.acknowledged_V)},
        {"zero_writes", out.zero_writes},
        {"zero_status", hal::to_string(out.zero_status)},
        {"enabled_ever", out.enabled_ever},
        {"enable_status", hal::to_string(out.enable_status)}}},
      {"drive", health_with_timing_json(run.runner->drive_health())},
      {"sensor", health_with_timing_json(run.runner->sensor_health())},
      {"realtime", run.runner->realtime_notes()},
      {"samples", {{"drive", drive_recorder_.next()}, {"sensor", sensor_recorder_.next()}}}};
  if (run.move) {
    run.summary["move"] = move_json(run);
    // The move's own zero, to the last bit, when it took one because the
    // board had none; a zero acknowledged before the move is never undone.
    if (const double z = run.move->zero_displacement_m();
        run.move_takes_its_zero && !std::isnan(z)) {
      zero_displacement_m_ = z;
    }
  }
  if (run.calibration) {
    const auto& result = run.calibration->result();
    if (result.complete && cause == firmware::StopCause::completed) {
      try {
        install_calibration(
            checked_calibration(calibration_json(run.calibration->plan(), result),
                                {board_.drive.limits.V_max, board_.drive.rate_hz / 20.0}));
        run.summary["calibration"] = *calibration_;
      } catch (const std::exception& e) {
        // Measurements no calibration can hold (no motion, a sensor that
        // saw nothing): the old calibration stays; the summary says why.
        run.summary["calibration"] = nullptr;
        run.summary["calibration_error"] = e.what();
        log_event(fmt::format("calibration not installed: {}", e.what()));
      }
    } else {
      run.summary["calibration"] = nullptr;
      run.summary["calibration_error"] = fmt::format(
          "the experiment ended {} before it was complete; the board keeps {}",
          firmware::to_string(cause), calibration_ ? "its calibration" : "no calibration");
    }
  }
  if (latches(cause) || std::string_view(firmware::output_state(out)) != "confirmed") {
    state_ = State::fault;
    fault_cause_ = latches(cause) ? cause : firmware::StopCause::drive_fault;
  } else {
    state_ = State::idle;
  }
  controller_.clear();
  log_event(fmt::format("run {} ended: {}, output {}{}", run.id, firmware::to_string(cause),
                        firmware::output_state(out),
                        state_ == State::fault ? " (fault latched: reset_fault to go on)" : ""));
  publish_state();
}

void Daemon::publish_state() {
  json j{
      {"state", to_string(state_)},
      {"board_ns", rig_.clock->now()},
      {"run", run_ ? json(run_->id) : json(nullptr)},
      {"fault", state_ == State::fault ? json(firmware::to_string(fault_cause_)) : json(nullptr)}};
  if (run_ && run_->finished) j["summary"] = run_->summary;
  const std::string body = protocol::encode_map(j);
  std::array<zmq::const_buffer, 2> parts{zmq::str_buffer("state"), zmq::buffer(body)};
  (void)zmq::send_multipart(stream_, parts, zmq::send_flags::dontwait);
}

void Daemon::publish_health() {
  json j{{"state", to_string(state_)}, {"board_ns", rig_.clock->now()}};
  if (running()) {
    j["drive"] = health_with_timing_json(run_->runner->drive_health());
    j["sensor"] = health_with_timing_json(run_->runner->sensor_health());
    if (run_->move) j["move"] = move_json(*run_);
    if (run_->calibration) j["calibration_progress"] = run_->calibration->progress();
  }
  const std::string body = protocol::encode_map(j);
  std::array<zmq::const_buffer, 2> parts{zmq::str_buffer("health"), zmq::buffer(body)};
  (void)zmq::send_multipart(stream_, parts, zmq::send_flags::dontwait);
}

}  // namespace piezo::daemon
