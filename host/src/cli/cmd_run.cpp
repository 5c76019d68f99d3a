// `piezo run`: drive the rig (real or simulated) for a duration and log it.

#include <fmt/format.h>
#include <unistd.h>

#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>

#include "board_client.hpp"
#include "calibration_report.hpp"
#include "catalogue.hpp"
#include "commands.hpp"
#include "config_error.hpp"
#include "effective_config.hpp"
#include "live_feed.hpp"
#include "local_board.hpp"
#include "log_schema.hpp"
#include "parameters_json.hpp"
#include "piezo/firmware/move_request.hpp"
#include "piezo/firmware/request_limits.hpp"
#include "piezo/overload.hpp"
#include "remote_run.hpp"
#include "rig.hpp"
#include "rig_config.hpp"
#include "run_log.hpp"
#include "run_session.hpp"
#include "signals.hpp"
#include "view_server.hpp"

namespace piezo::host {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> approach_names() {
  std::vector<std::string> out;
  for (const auto& [value, name] : firmware::kApproachNames.entries()) out.emplace_back(name);
  return out;
}

constexpr int kExitFailed = 1;
constexpr int kExitInterrupted = 130;  // the shell's code for SIGINT

struct RunOptions {
  std::vector<std::string> config;
  std::vector<std::string> sets;
  double duration = 0.0;  // 0: the config's [run] duration_s
  std::string out;
  std::string rig;  // piezod's address; empty: the config's [rig] address, or in-process
  bool json = false;
  // `piezo step`: whole drive periods instead of a duration.
  std::uint64_t step_periods = 0;
  bool reverse = false;
  std::optional<double> V0, f;
  // --view [HOST:PORT]: the live page; --control lets it stop and e-stop.
  bool view = false;
  std::string view_listen;
  bool control = false;
  std::vector<std::string> allow_hosts;
  // `piezo move`: a closed-loop move; the options the user gave (the
  // others come from the config's [move], or the declared defaults).
  bool move = false;
  firmware::MoveRequest move_request;
  std::vector<std::pair<const firmware::MoveField*, const CLI::Option*>> move_options;
  // `piezo calibrate`: the board's designed experiment, then the fit.
  bool calibrate = false;
};

std::string utc_stamp(const char* format) {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[64];
  std::strftime(buf, sizeof buf, format, &tm);
  return buf;
}

std::string host_name() {
  char buf[256] = {};
  gethostname(buf, sizeof buf - 1);
  return buf;
}

/// Whether a run may be written into `dir`: it does not exist or is empty.
bool free_for_a_run(const fs::path& dir) {
  return !fs::exists(dir) || (fs::is_directory(dir) && fs::is_empty(dir));
}

/// The run directory: --out, or runs/<UTC time>, with -2, -3, ... when runs
/// of that second exist already (a script's moves follow each other within
/// one). --out must not hold a run already.
fs::path choose_run_dir(const std::string& out) {
  fs::path dir = out;
  if (out.empty()) {
    const std::string stamp = utc_stamp("%Y%m%dT%H%M%SZ");
    dir = fs::path("runs") / stamp;
    for (int n = 2; !free_for_a_run(dir); ++n)
      dir = fs::path("runs") / fmt::format("{}-{}", stamp, n);
  }
  if (!free_for_a_run(dir)) {
    throw config::ConfigError("--out", dir.string(), "exists and is not an empty directory");
  }
  // Where it will be created must be writable: refused now (exit 2), not
  // after the rig is set up.
  fs::path existing = fs::absolute(dir);
  while (!fs::exists(existing) && existing.has_parent_path() &&
         existing != existing.parent_path()) {
    existing = existing.parent_path();
  }
  // A probe, not access(): root passes access() where nothing can be made.
  const fs::path probe = existing / fmt::format(".piezo-write-probe-{}", getpid());
  std::error_code error;
  if (!fs::create_directory(probe, error)) {
    throw config::ConfigError("--out", dir.string(),
                              fmt::format("cannot be created in {}: {}", existing.string(),
                                          error ? error.message() : std::string("it exists")));
  }
  fs::remove(probe, error);
  return dir;
}

/// A loop's health as the board reported it (its timing zero when none
/// came), and its failed samples by class as the host counted them.
nlohmann::json loop_json(const protocol::LoopHealth& h,
                         const std::map<std::string, std::uint64_t>& errors_by_class) {
  const auto timing = h.timing.value_or(protocol::LoopHealth::Timing{});
  return {{"samples", h.cycles},
          {"overruns", h.overruns},
          {"missed_cycles", h.missed_cycles},
          {"dropped", h.dropped},
          {"errors", h.errors},
          {"errors_by_class", errors_by_class},
          {"period_error_us",
           {{"p50", timing.p50_us},
            {"p99", timing.p99_us},
            {"max", timing.max_us},
            {"mean", timing.mean_us}}}};
}

/// A calibration run's result as the run's JSON keeps it: the calibration
/// installed (nil when none was) and why not.
nlohmann::json calibration_result(const protocol::RunSummary& b) {
  return {{"calibration", b.calibration},
          {"error",
           b.calibration_error ? nlohmann::json(*b.calibration_error) : nlohmann::json(nullptr)}};
}

/// Writes to a stream whose reader may be gone (a closed pipe, a closed
/// terminal): a failed write is dropped, the run goes on.
void write_out(std::FILE* stream, const std::string& text) {
  (void)std::fputs(text.c_str(), stream);
  (void)std::fflush(stream);
}

nlohmann::json output_json(const RunSummary& s) {
  const auto& o = s.board.output;
  return {{"state", s.output_state()},
          {"zero_confirmed", o.zero_confirmed},
          {"zero_read_back", o.zero_read_back},
          {"last_acknowledged_V",
           o.acknowledged_V ? nlohmann::json(*o.acknowledged_V) : nlohmann::json(nullptr)},
          {"enable_status", o.enable_status},
          {"zero_status", o.zero_status},
          {"zero_writes", o.zero_writes}};
}

nlohmann::json summary_json(const RunSummary& s, const fs::path& dir, const fs::path& log,
                            const std::string& signal) {
  nlohmann::json observer = nullptr;
  if (s.observer) {
    observer = {{"samples", s.observer->samples},
                {"residual_rms_rad", s.observer->residual_rms_rad},
                {"open_loop_rms_rad", s.observer->open_loop_rms_rad},
                {"outliers", s.observer->outliers},
                {"restarts", s.observer->restarts}};
  }
  return {{"status", s.status()},
          {"observer", observer},
          {"stop_cause", s.stop_cause()},
          {"stop_signal", signal.empty() ? nlohmann::json(nullptr) : nlohmann::json(signal)},
          {"error", s.host_error.empty() ? nlohmann::json(nullptr) : nlohmann::json(s.host_error)},
          {"output", output_json(s)},
          {"run_dir", dir.string()},
          {"log", log.string()},
          {"drive", loop_json(s.board.drive, s.drive_errors)},
          {"sensor", loop_json(s.board.sensor, s.sensor_errors)},
          {"theta_end_rad", s.theta_end_rad},
          {"t_end_s", s.t_end_s},
          {"mean_velocity_rad_s", s.mean_velocity_rad_s},
          {"realtime", s.board.realtime}};
}

/// The one line that says how the output was left, in plain words.
std::string output_line(const RunSummary& s) {
  const auto& o = s.board.output;
  if (s.output_state() == "unknown") {
    return "OUTPUT STATE UNKNOWN: the board fell silent before it reported how it left the "
           "output. Its lease stops the drive by itself; check the amplifier before touching "
           "the rig.";
  }
  if (s.output_state() == "output_unconfirmed") {
    const std::string last = o.acknowledged_V
                                 ? fmt::format("it last acknowledged {:.3f} V", *o.acknowledged_V)
                                 : "no value was ever acknowledged";
    return fmt::format(
        "OUTPUT UNCONFIRMED: the drive did not acknowledge 0 V after {} writes ({}); {}. The "
        "output may still be live: check the amplifier, its enable line and the module's "
        "watchdog before touching the rig.",
        o.zero_writes, o.zero_status, last);
  }
  if (s.output_state() == "enable_unconfirmed") {
    return fmt::format(
        "ENABLE UNCONFIRMED: 0 V acknowledged, but dropping the amplifier enable "
        "failed ({})",
        o.enable_status);
  }
  return "0 V acknowledged by the drive, amplifier disabled";
}

std::string summary_text(const RunSummary& s, const fs::path& log, const std::string& signal,
                         const nlohmann::json& steps) {
  std::string out = fmt::format("run {} ({}{})\n", s.status(), s.stop_cause(),
                                signal.empty() ? "" : ", " + signal);
  if (steps.is_object()) {
    out += fmt::format(
        "  steps      {} {}: travel {:.4f} mrad, mean step {:.2f} urad\n",
        steps.at("count").get<std::uint64_t>(), steps.at("direction").get<std::string>(),
        1e3 * steps.at("travel_rad").get<double>(), 1e6 * steps.at("mean_step_rad").get<double>());
  }
  if (!s.host_error.empty()) out += fmt::format("  error      {}\n", s.host_error);
  out += fmt::format("  output     {}\n", output_line(s));
  out += fmt::format("  angle      {:.4f} mrad at t = {:.3f} s, mean velocity {:.4f} mrad/s\n",
                     1e3 * s.theta_end_rad, s.t_end_s, 1e3 * s.mean_velocity_rad_s);
  for (const auto& [name, l] :
       {std::pair{"drive", &s.board.drive}, std::pair{"sensor", &s.board.sensor}}) {
    const auto timing = l->timing.value_or(protocol::LoopHealth::Timing{});
    out += fmt::format(
        "  {:<7}    {} samples, {} errors, {} dropped, {} overruns ({} missed); "
        "period error p50 {:.0f} us, p99 {:.0f} us, max {:.1f} us\n",
        name, l->cycles, l->errors, l->dropped, l->overruns, l->missed_cycles, timing.p50_us,
        timing.p99_us, timing.max_us);
  }
  if (s.observer) {
    out += fmt::format(
        "  observer   residual {:.2f} urad rms (open-loop model {:.2f} urad rms) over {} samples\n",
        1e6 * s.observer->residual_rms_rad, 1e6 * s.observer->open_loop_rms_rad,
        s.observer->samples);
  }
  for (const auto& note : s.board.realtime) out += fmt::format("  real time  {}\n", note);
  out += fmt::format("  log        {}\n", log.string());
  return out;
}

void append_catalogue(const fs::path& run_dir, const std::string& utc_start,
                      const config::RigConfig& config, const RunSummary& s) {
  append_to_catalogue(run_dir, {.utc_start = utc_start,
                                .status = s.status(),
                                .stop_cause = s.stop_cause(),
                                .config = config.source,
                                .t_end_s = s.t_end_s,
                                .theta_end_rad = s.theta_end_rad});
}

void show_status(const LiveStatus& st) {
  static const bool tty = isatty(STDERR_FILENO) != 0;
  static auto last_line = std::chrono::steady_clock::time_point{};
  const double progress = st.board.value("calibration_progress", -1.0);
  const std::string line = fmt::format(
      "{}t {:6.2f}/{:.2f} s  V {:5.1f} V  theta {:8.4f} mrad  residual {:6.1f} urad  sensor {} "
      "({} errors)  overruns {}",
      progress >= 0.0 ? fmt::format("calibrating {:3.0f} %  ", 100.0 * progress) : std::string(),
      st.t_s, st.duration_s, st.V, 1e3 * st.theta_rad, 1e6 * st.residual_rad, st.sensor_samples,
      st.sensor_errors, st.overruns);
  if (tty) {
    write_out(stderr, "\r" + line + "\x1b[K");
  } else if (std::chrono::steady_clock::now() - last_line > std::chrono::seconds(1)) {
    write_out(stderr, line + "\n");
    last_line = std::chrono::steady_clock::now();
  }
}

/// Writes the end of the log: results, then the final status. A log that
/// cannot be finished fails the run; what was flushed stays readable.
void finish_log(RunLog& log, RunSummary& summary, const nlohmann::json& result) {
  if (log.broken()) {
    log.abandon();  // a log that failed half-way is not written again
    return;
  }
  try {
    const auto histogram = [](const protocol::LoopHealth& h) {
      return h.timing ? h.timing->histogram_us : std::vector<double>{};
    };
    log.write(log_schema::kDrivePeriodErrorUs, histogram(summary.board.drive));
    log.write(log_schema::kAcquirePeriodErrorUs, histogram(summary.board.sensor));
    log.set_attribute(log_schema::kSummary, result.dump());
    log.set_attribute(log_schema::kRealtime,
                      fmt::format("{}", fmt::join(summary.board.realtime, "; ")));
    log.set_attribute(log_schema::kStopCause, summary.stop_cause());
    log.set_attribute(log_schema::kOutput, summary.output_state());
    log.close(summary.status());
  } catch (const std::exception& e) {
    if (summary.host_error.empty()) summary.host_error = e.what();
    log.abandon();
  }
}

/// `piezo move`'s result: the board's account of the move, the time it took
/// and the run it was, in one object.
nlohmann::json move_result(const RunSummary& s, const nlohmann::json& run) {
  nlohmann::json m = s.board.move.is_object() ? s.board.move : nlohmann::json::object();
  if (!m.contains("stop_cause")) m["stop_cause"] = s.stop_cause();
  if (!m.contains("on_target")) m["on_target"] = false;
  for (const char* key : {"position_rad", "error_rad", "steps"}) {
    if (!m.contains(key)) m[key] = nullptr;
  }
  const bool on_target = m.at("on_target").get<bool>();
  m["time_s"] = on_target ? m.at("on_target_at_s") : nlohmann::json(s.t_end_s);
  m["run_dir"] = run.at("run_dir");
  m["log"] = run.at("log");
  m["run"] = run;
  return m;
}

std::string move_text(const nlohmann::json& m) {
  const auto mrad = [](const nlohmann::json& v) {
    return v.is_number() ? fmt::format("{:.4f} mrad", 1e3 * v.get<double>()) : std::string("-");
  };
  const auto urad = [](const nlohmann::json& v) {
    return v.is_number() ? fmt::format("{:.1f} urad", 1e6 * v.get<double>()) : std::string("-");
  };
  return fmt::format("move {} ({}): position {} for target {}, error {}, {} steps, {:.3f} s\n",
                     m.at("on_target").get<bool>() ? "on target" : "NOT on target",
                     m.at("stop_cause").get<std::string>(),
                     mrad(m.value("position_rad", nlohmann::json())),
                     mrad(m.value("target_rad", nlohmann::json())), urad(m.at("error_rad")),
                     m.at("steps").is_number() ? m.at("steps").get<long>() : 0L,
                     m.at("time_s").is_number() ? m.at("time_s").get<double>() : 0.0);
}

int exit_code(const RunSummary& summary) {
  if (summary.status() == "completed") return 0;
  if (summary.status() == "interrupted") return kExitInterrupted;
  return kExitFailed;
}

/// `piezo calibrate`'s end: the fit, the files and the board told, or why not.
int report_calibration(const RunOptions& o, const RunSummary& summary, nlohmann::json result,
                       const fs::path& dir, const fs::path& log_path,
                       const config::RigConfig& config, BoardClient& client, bool local) {
  const nlohmann::json& measured = summary.board.calibration;
  if (!summary.board.has_calibration || measured.is_null() || summary.status() != "completed") {
    const std::string why = summary.board.calibration_error
                                ? *summary.board.calibration_error
                                : fmt::format("the run ended {}", summary.stop_cause());
    result["calibration"] = nullptr;
    result["calibration_error"] = why;
    write_out(stdout, o.json ? result.dump() + "\n"
                             : summary_text(summary, log_path, std::string(), nullptr));
    write_out(stderr, fmt::format("piezo: calibration failed: {}\n", why));
    return kExitFailed;
  }
  const CalibrationReport report =
      finish_calibration(dir, log_path, measured, config, client, local);
  result["calibration"] = report.calibration;
  result["kept"] = report.kept;
  result["files"] = {
      {"calibration", report.file.string()},
      {"plot", report.plot.empty() ? nlohmann::json() : nlohmann::json(report.plot.string())},
      {"summary", report.summary.string()}};
  if (o.json) {
    write_out(stdout, result.dump() + "\n");
  } else {
    const auto& c = report.calibration;
    write_out(
        stdout,
        fmt::format("calibrated: fastest reliable step frequency {}, noise {:.3g} m, "
                    "smallest tolerance {:.3g} rad, {:.4g} urad/V in stick{}\n"
                    "kept {}\nsummary {}\n",
                    c.at("fastest_f_hz").is_number()
                        ? fmt::format("{:g} Hz", c.at("fastest_f_hz").get<double>())
                        : std::string("none"),
                    c.at("noise_m").get<double>(), c.at("smallest_tolerance_rad").get<double>(),
                    1e6 * c.at("rad_per_V").get<double>(),
                    c.at("model").is_object()
                        ? fmt::format(", model fitted (RMSE {:.2f} urad)",
                                      1e6 * c.at("model").at("rmse_rad").get<double>())
                        : std::string(),
                    report.kept, report.summary.string()));
  }
  return 0;
}

/// `piezo move`'s request: each field from its option when the user gave
/// it, else from the config's [move]. The board refuses the same (one
/// rule); checked here first so that a refused move leaves no run
/// directory behind.
config::RunSettings::Move move_request(const RunOptions& o, const firmware::MoveRequest& defaults) {
  config::RunSettings::Move move;
  static_cast<firmware::MoveRequest&>(move) = defaults;
  for (const auto& [field, option] : o.move_options) {
    if (option->count() == 0) continue;
    std::visit([&](auto member) { move.*member = o.move_request.*member; }, field->member);
  }
  if (const auto breach = firmware::check_move(move)) {
    const firmware::MoveField* field = firmware::find_move_field(breach->key);
    throw config::ConfigError(field ? std::string(field->option) : "piezo move", breach->key,
                              breach->message);
  }
  move.V0 = o.V0;
  move.f = o.f;
  return move;
}

/// The run's config: the file and --set, the command's own options (steps,
/// a move, the calibration) and the board's address.
config::RigConfig rig_config(const RunOptions& o) {
  std::vector<std::string> sets = o.sets;
  if (o.duration > 0.0) sets.push_back(fmt::format("run.duration_s={}", o.duration));
  if (o.V0) sets.push_back(fmt::format("drive.V0={}", *o.V0));
  if (o.f) sets.push_back(fmt::format("drive.f={}", *o.f));
  if (o.reverse) sets.emplace_back("drive.direction=reverse");
  if (o.config.empty() && o.rig.empty()) {
    throw config::ConfigError("command line", "--config",
                              "required, or --rig ADDRESS (a board with its own config)");
  }
  config::RigConfig config = config::load_rig_config(o.config, sets);
  if (o.step_periods > 0) {
    config.run.step_periods = o.step_periods;
    config.run.duration_s = static_cast<double>(o.step_periods) / config.model.drive.f;
  }
  if (o.move) config.run.move = move_request(o, config.run.move_defaults);
  if (config.run.move) config.run.duration_s = config.run.move->timeout_s;
  if (o.calibrate) {
    config.run.calibrate = config::RunSettings::Calibrate{o.V0};
    config.run.duration_s = 60.0;  // the board's plan says how long; its start reply tells
  }
  if (!o.rig.empty()) config.board.address = o.rig;
  return config;
}

/// What drives: piezod at an address, or the firmware in this process
/// (reached through the protocol all the same, until the report is done).
struct Board {
  std::unique_ptr<LocalBoard> local;  ///< declared first: its context outlives the client
  std::optional<BoardClient> client;
  protocol::Hello hello;
  std::string geometry_note;  ///< the board's sensor radius differed from the config's
};

void connect(Board& board, config::RigConfig& config) {
  if (config.board.address.empty()) {
    board.local = std::make_unique<LocalBoard>(config, config::build_rig(config));
    board.client.emplace(config::BoardAddress{board.local->address(), "", ""},
                         board.local->context());
  } else {
    board.client.emplace(config.board);
  }
  board.hello = board.client->hello();
  if (const std::string note = adopt_board_sensor(config, board.hello); !note.empty()) {
    write_out(stderr, "piezo: " + note + "\n");
    board.geometry_note = note;
  }
  configure_remote(config, *board.client);
}

/// The live view, bound before anything is created: a busy port is bad input.
std::unique_ptr<view::ViewServer> open_view(const RunOptions& o, const fs::path& dir,
                                            view::LiveFeed& live, const StopOnSignals& signals,
                                            std::atomic<bool>& estop_requested) {
  auto server = std::make_unique<view::ViewServer>(
      view::ViewOptions{o.view_listen.empty() ? "127.0.0.1:8080" : o.view_listen,
                        fs::absolute(dir).parent_path().string(), o.control, o.allow_hosts},
      &live,
      view::ViewControls{[&signals](const nlohmann::json&) {
                           signals.request_stop();
                           return nlohmann::json::object();
                         },
                         [&estop_requested](const nlohmann::json&) {
                           estop_requested.store(true);
                           return nlohmann::json::object();
                         },
                         {}});
  write_out(stderr, server->banner() + "\n");
  return server;
}

/// The run's directory and log, once everything is checked: only now does
/// the run leave traces.
RunLog create_log(const fs::path& dir, const config::RigConfig& config, const Board& board,
                  const std::string& utc_start) {
  fs::create_directories(dir);
  if (!fs::is_empty(dir)) {
    // Another run took the name between the check and now: never mix two.
    throw config::ConfigError("--out", dir.string(), "was taken by another run meanwhile");
  }
  std::ofstream(dir / "config.toml") << config::run_config_file(config);
  const bool remote = !board.local;
  RunLog log = RunLog::create(
      (dir / "run.h5").string(),
      {{log_schema::kConfig, config.text},
       {log_schema::kConfigSource, config.source},
       {log_schema::kModelParameters, to_json(config.model).dump()},
       {log_schema::kPlantParameters,
        to_json(model::Parameters{config.model.drive, config.plant}).dump()},
       {log_schema::kVersion, PIEZO_VERSION},
       {log_schema::kUtcStart, utc_start},
       {log_schema::kHost, host_name()},
       {log_schema::kClock, remote ? board.hello.clock : std::string(name(config.run.clock))},
       {log_schema::kDriveLatency, fmt::format("{:.9g}", board.hello.output_latency_s)},
       {log_schema::kTimeOrigin, "seconds from the run's start (first drive deadline)"},
       {log_schema::kTheta,
        fmt::format("(displacement - first good displacement) / sensor.r2_m, "
                    "r2_m = {:.9g} m{}",
                    config.sensor.r2_m, remote ? " (the board's, from its hello)" : "")}});
  if (!board.geometry_note.empty())
    log.set_attribute(log_schema::kSensorGeometryNote, board.geometry_note);
  return log;
}

/// The terminal's status line and the live page's status, as a run reports.
std::function<void(const LiveStatus&)> status_reporter(const RunOptions& o, view::LiveFeed* live) {
  if (o.json && live == nullptr) return {};
  return [&o, live](const LiveStatus& st) {
    if (!o.json) show_status(st);
    if (live == nullptr) return;
    live->set_status({{"t_s", st.t_s},
                      {"duration_s", st.duration_s},
                      {"V", st.V},
                      {"theta_rad", st.theta_rad},
                      {"residual_rad", st.residual_rad},
                      {"sensor_samples", st.sensor_samples},
                      {"sensor_errors", st.sensor_errors},
                      {"overruns", st.overruns},
                      {"board", st.board},
                      {"errors_by_class", st.errors_by_class},
                      {"lease_s", st.lease_s}});
  };
}

/// Runs it; a failure before the run's end leaves the log marked failed
/// with the reason (the log keeps what it has) and is thrown on.
RunSummary drive(Board& board, const config::RigConfig& config, RunLog& log,
                 const StopOnSignals& signals,
                 const std::function<void(const LiveStatus&)>& status_line,
                 const std::atomic<bool>& estop_requested) {
  try {
    const std::optional<double> lease = board.local ? std::optional(LocalBoard::kLease_s)
                                        : config.board.lease_s > 0.0
                                            ? std::optional(config.board.lease_s)
                                            : std::nullopt;
    RunSummary summary = execute_remote_run(config, *board.client, board.hello, log, signals.flag(),
                                            status_line, lease, &estop_requested);
    if (board.local && !log.broken()) {
      log.set_attribute(log_schema::kBoardEvents, board.local->events());
    }
    return summary;
  } catch (const std::exception& e) {
    if (!log.broken()) {
      try {
        log.set_attribute(log_schema::kStopCause, "host_error");
        log.set_attribute(log_schema::kError, e.what());
        log.close("failed");
      } catch (const std::exception&) {
        log.abandon();
      }
    }
    throw;
  }
}

/// What the command prints, and its exit code.
int report(const RunOptions& o, const RunSummary& summary, const config::RigConfig& config,
           const fs::path& dir, const fs::path& log_path, Board& board, const std::string& signal) {
  // The result, rebuilt: finishing the log may have failed the run.
  nlohmann::json result = summary_json(summary, dir, log_path, signal);
  if (!summary.board.move.is_null()) result["move"] = summary.board.move;
  nlohmann::json steps = nullptr;
  if (o.step_periods > 0) {
    steps = {{"count", o.step_periods},
             {"direction", model::name(config.model.drive.direction)},
             {"travel_rad", summary.theta_end_rad},
             {"mean_step_rad", summary.theta_end_rad / static_cast<double>(o.step_periods)}};
    result["steps"] = steps;
  }
  if (o.calibrate) {
    return report_calibration(o, summary, result, dir, log_path, config, *board.client,
                              board.local != nullptr);
  }
  if (o.move) {
    const nlohmann::json move = move_result(summary, result);
    write_out(stdout, o.json ? move.dump() + "\n"
                             : move_text(move) + summary_text(summary, log_path, signal, steps));
    if (summary.output_state() != "confirmed") {
      write_out(stderr, "piezo: " + output_line(summary) + "\n");
    }
    if (exit_code(summary) != 0) return exit_code(summary);
    return move.at("on_target").get<bool>() ? 0 : kExitFailed;
  }
  write_out(stdout, o.json ? result.dump() + "\n" : summary_text(summary, log_path, signal, steps));
  if (summary.output_state() != "confirmed") {
    write_out(stderr, "piezo: " + output_line(summary) + "\n");
  }
  if (!summary.host_error.empty()) {
    write_out(stderr, fmt::format("piezo: error: {}\n", summary.host_error));
  }
  return exit_code(summary);
}

int run(const RunOptions& o) {
  // From here on every stopping signal ends the run through the ramp; one
  // that comes during set-up stops it before the amplifier is enabled.
  const StopOnSignals signals;
  config::RigConfig config = rig_config(o);
  const fs::path dir = choose_run_dir(o.out);
  Board board;
  connect(board, config);
  std::optional<view::LiveFeed> live;
  std::unique_ptr<view::ViewServer> server;
  std::atomic<bool> estop_requested{false};
  if (o.view) {
    live.emplace(20.0, 3.0 / config.model.drive.f);
    server = open_view(o, dir, *live, signals, estop_requested);
  }
  const std::string utc_start = utc_stamp("%Y-%m-%dT%H:%M:%SZ");
  const fs::path log_path = dir / "run.h5";
  RunLog log = create_log(dir, config, board, utc_start);
  if (live) log.set_tap([&live](const log_schema::LogRows& rows) { live->add(rows); });
  RunSummary summary = drive(board, config, log, signals,
                             status_reporter(o, live ? &*live : nullptr), estop_requested);
  if (!o.json && isatty(STDERR_FILENO)) write_out(stderr, "\n");
  // The log keeps the move's account (target, controller's result) too.
  nlohmann::json logged = summary_json(summary, dir, log_path, signals.received());
  if (!summary.board.move.is_null()) logged["move"] = summary.board.move;
  if (summary.board.has_calibration) logged["calibration"] = calibration_result(summary.board);
  finish_log(log, summary, logged);
  try {
    append_catalogue(dir, utc_start, config, summary);
  } catch (const std::exception& e) {
    write_out(stderr, fmt::format("piezo: warning: catalogue not updated: {}\n", e.what()));
  }
  return report(o, summary, config, dir, log_path, board, signals.received());
}

}  // namespace

/// --view and --control, for every command that drives the rig.
CommandRunner with_view_options(CLI::App* cmd, const std::shared_ptr<RunOptions>& o) {
  cmd->add_option("--view", o->view_listen,
                  "Serve the live page to a browser on HOST:PORT (default 127.0.0.1:8080)")
      ->expected(0, 1);
  cmd->add_flag("--control", o->control,
                "Let the live page stop and e-stop the run (with the token it prints)");
  cmd->add_option("--allow-host", o->allow_hosts,
                  "A host name the live page may be reached by besides its address and the "
                  "loopback names (repeatable)");
  return [o, cmd]() {
    if (!cmd->parsed()) return -1;
    o->view = cmd->count("--view") > 0;
    return run(*o);
  };
}

CommandRunner add_run_command(CLI::App& app) {
  auto o = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand("run", "Drive the rig and log the run");
  cmd->add_option("--config", o->config,
                  "Rig config (TOML); a second one overlays the first (e.g. fitted parameters)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--set", o->sets, "Override a config key: SECTION.KEY=VALUE");
  cmd->add_option("--duration", o->duration, "Run time [s] (default: [run] duration_s)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--out", o->out, "Run directory (default: runs/<UTC time>)");
  cmd->add_option("--rig", o->rig,
                  "piezod's address, e.g. tcp://board:5555 (default: [rig] address, or the "
                  "firmware in this process)");
  cmd->add_flag("--json", o->json, "Print one JSON summary on stdout");
  cmd->add_flag("--reverse", o->reverse, "Drive the mirrored sawtooth: the rotor turns backwards");
  return with_view_options(cmd, o);
}

/// One option per declared field of a move's request (kMoveFields).
void add_move_options(CLI::App& cmd, RunOptions& o) {
  for (const firmware::MoveField& field : firmware::kMoveFields) {
    const std::string option(field.option);
    const std::string unit = field.unit.empty() ? "" : " [" + std::string(field.unit) + "]";
    std::string doc = std::string(field.doc) + unit;
    doc[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(doc[0])));
    if (!field.required) {
      doc += " (default: [move] " + std::string(field.name) + ", else " +
             firmware::default_text(field) + ")";
    }
    CLI::Option* added =
        std::visit(Overload{
                       [&](double firmware::MoveRequest::*m) {
                         return cmd.add_option(option, o.move_request.*m, doc);
                       },
                       [&](std::uint64_t firmware::MoveRequest::*m) {
                         return cmd.add_option(option, o.move_request.*m, doc)
                             ->check(CLI::Range(static_cast<std::uint64_t>(field.allowed.min),
                                                static_cast<std::uint64_t>(field.allowed.max)));
                       },
                       [&](bool firmware::MoveRequest::*m) {
                         // The flag says the opposite of the default ("--no-protect").
                         const bool flagged = !(firmware::MoveRequest{}.*m);
                         return cmd.add_flag_callback(
                             option, [&o, m, flagged] { o.move_request.*m = flagged; }, doc);
                       },
                       [&](firmware::Approach firmware::MoveRequest::*m) {
                         return cmd
                             .add_option_function<std::string>(
                                 option,
                                 [&o, m](const std::string& text) {
                                   o.move_request.*m = *firmware::kApproachNames.parse(text);
                                 },
                                 doc)
                             ->check(CLI::IsMember(approach_names()));
                       },
                   },
                   field.member);
    if (field.required) added->required();
    o.move_options.emplace_back(&field, added);
  }
}

CommandRunner add_move_command(CLI::App& app) {
  auto o = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand(
      "move", "Closed-loop move to an angle from the board's zero (logged as a run)");
  o->move = true;
  add_move_options(*cmd, *o);
  cmd->add_option("--config", o->config,
                  "Rig config (TOML), as for `piezo run` (with --rig: default Table 1)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--V0", o->V0, "Coarse steps' peak voltage [V] (default: [drive] V0)");
  cmd->add_option("--f", o->f,
                  "Coarse steps' frequency [Hz] (default: the board's calibrated fastest, else "
                  "its [drive] f)");
  cmd->add_option("--set", o->sets, "Override a config key: SECTION.KEY=VALUE");
  cmd->add_option("--out", o->out, "Run directory (default: runs/<UTC time>)");
  cmd->add_option("--rig", o->rig, "piezod's address (default: [rig] address, or in-process)");
  cmd->add_flag("--json", o->json,
                "Print one JSON object: position_rad, error_rad, on_target, time_s, steps, "
                "stop_cause, ... and the run");
  return with_view_options(cmd, o);
}

CommandRunner add_calibrate_command(CLI::App& app) {
  auto o = std::make_shared<RunOptions>();
  o->calibrate = true;
  CLI::App* cmd = app.add_subcommand(
      "calibrate",
      "Measure the rig (steps both ways at several amplitudes and frequencies, DC holds, the "
      "sensor's noise), fit the model, and give the board the calibration its moves use");
  cmd->add_option("--config", o->config,
                  "Rig config (TOML), as for `piezo run` (with --rig: default Table 1)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--V0", o->V0, "Peak voltage of the steps [V] (default: the board's [drive] V0)");
  cmd->add_option("--set", o->sets, "Override a config key: SECTION.KEY=VALUE");
  cmd->add_option("--out", o->out, "Run directory (default: runs/<UTC time>)");
  cmd->add_option("--rig", o->rig, "piezod's address (default: [rig] address, or in-process)");
  cmd->add_flag("--json", o->json,
                "Print one JSON object: the calibration, where it is kept, files");
  return with_view_options(cmd, o);
}

CommandRunner add_step_command(CLI::App& app) {
  auto o = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand(
      "step", "Drive exactly N periods (steps) and report the measured travel; logged as a run");
  cmd->add_option("count", o->step_periods, "Number of steps (whole drive periods)")
      ->required()
      ->check(CLI::Range(std::uint64_t{1}, std::uint64_t{1'000'000}));
  cmd->add_option("--config", o->config,
                  "Rig config (TOML), as for `piezo run` (with --rig: default Table 1)")
      ->check(CLI::ExistingFile);
  cmd->add_flag("--reverse", o->reverse, "Step backwards (the mirrored sawtooth)");
  cmd->add_option("--V0", o->V0, "Peak voltage [V] (default: [drive] V0)");
  cmd->add_option("--f", o->f, "Drive frequency [Hz] (default: [drive] f)");
  cmd->add_option("--set", o->sets, "Override a config key: SECTION.KEY=VALUE");
  cmd->add_option("--out", o->out, "Run directory (default: runs/<UTC time>)");
  cmd->add_option("--rig", o->rig, "piezod's address (default: [rig] address, or in-process)");
  cmd->add_flag("--json", o->json, "Print one JSON summary on stdout");
  return with_view_options(cmd, o);
}

}  // namespace piezo::host
