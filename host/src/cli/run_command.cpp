// What the run commands share (run_command.hpp): their options, the run
// directory, the live view and status line, the run's JSON and the plain
// report. The run's session with its board (connect, checks, the log's
// header and end, the drive) is run/run_setup.cpp's.

#include "run_command.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <fstream>

#include "commands.hpp"
#include "config/effective_config.hpp"
#include "config/rig.hpp"
#include "exit_codes.hpp"
#include "io/catalogue.hpp"
#include "io/log_schema.hpp"
#include "io/parameters_json.hpp"
#include "io/run_log.hpp"
#include "piezo/config/config_error.hpp"
#include "piezo/firmware/output_state.hpp"
#include "piezo/firmware/wire_keys.hpp"
#include "run/board_run.hpp"
#include "run/local_board.hpp"
#include "run/run_setup.hpp"
#include "run/signals.hpp"
#include "view/live_feed.hpp"
#include "view/view_server.hpp"

namespace piezo::host {

namespace fs = std::filesystem;

void write_out(std::FILE* stream, const std::string& text) {
  (void)std::fputs(text.c_str(), stream);
  (void)std::fflush(stream);
}

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
  for (const AxisMeasured& m : s.axes) {
    out +=
        fmt::format("  angle      {:<7}{:.4f} mrad at t = {:.3f} s, mean velocity {:.4f} mrad/s\n",
                    m.name, 1e3 * m.theta_end_rad, m.t_end_s, 1e3 * m.mean_velocity_rad_s);
  }
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

int exit_code(const RunSummary& summary) {
  if (summary.status() == "completed") return 0;
  if (summary.status() == "interrupted") return kExitInterrupted;
  return kExitFailed;
}

int print_run(const FinishedRun& run, const nlohmann::json& result, const nlohmann::json& steps) {
  const RunSummary& summary = run.summary;
  write_out(stdout, run.options.json ? result.dump() + "\n"
                                     : summary_text(summary, run.log, run.signal, steps));
  if (summary.output_state() != "confirmed") {
    write_out(stderr, "piezo: " + output_line(summary) + "\n");
  }
  if (!summary.host_error.empty()) {
    write_out(stderr, fmt::format("piezo: error: {}\n", summary.host_error));
  }
  return exit_code(summary);
}

namespace {

std::string utc_stamp(const char* format) {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[64];
  std::strftime(buf, sizeof buf, format, &tm);
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
  return {{"calibration",
           b.calibration.value ? nlohmann::json(*b.calibration.value) : nlohmann::json(nullptr)},
          {"error",
           b.calibration_error ? nlohmann::json(*b.calibration_error) : nlohmann::json(nullptr)}};
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

nlohmann::json observer_json(const std::optional<ObserverSummary>& o) {
  if (!o) return nullptr;
  return {{"samples", o->samples},
          {"residual_rms_rad", o->residual_rms_rad},
          {"open_loop_rms_rad", o->open_loop_rms_rad},
          {"outliers", o->outliers},
          {"restarts", o->restarts}};
}

/// Each axis of a run of several: how it ended (the board's account) and
/// what the host measured of it, in the log's order.
nlohmann::json axes_json(const RunSummary& s) {
  nlohmann::json out = nlohmann::json::array();
  for (const AxisMeasured& m : s.axes) {
    nlohmann::json a = {
        {"name", m.name},
        {"theta_end_rad", m.theta_end_rad},
        {"t_end_s", m.t_end_s},
        {"mean_velocity_rad_s", m.mean_velocity_rad_s},
        {"errors_by_class", {{"drive", m.drive_errors}, {"sensor", m.sensor_errors}}},
        {"observer", observer_json(m.observer)}};
    for (const auto& b : s.board.axes) {
      if (b.name != m.name) continue;
      a["stop_cause"] = axis_end(b);
      a["output"] = firmware::kOutputStateNames.name(b.output.state);
      a["move"] = b.move ? nlohmann::json(*b.move) : nlohmann::json(nullptr);
      if (b.scan) {
        protocol::ScanAccount scan = *b.scan;
        scan.pulses.reset();  // each one is a row of the axis's /triggers
        a["scan"] = scan;
      }
    }
    out.push_back(std::move(a));
  }
  return out;
}

nlohmann::json summary_json(const RunSummary& s, const fs::path& dir, const fs::path& log,
                            const std::string& signal) {
  nlohmann::json out = {
      {"status", s.status()},
      {"observer", observer_json(s.observer)},
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
  out["axes"] = axes_json(s);  // every axis of the run, one as several
  return out;
}

void append_catalogue(const fs::path& run_dir, const std::string& utc_start,
                      const config::ConfigFile& config, const RunSummary& s) {
  CatalogueEntry entry{.utc_start = utc_start,
                       .status = s.status(),
                       .stop_cause = s.stop_cause(),
                       .config = config.source,
                       .t_end_s = s.t_end_s,
                       .axes = {}};
  for (const AxisMeasured& a : s.axes) entry.axes.push_back({a.name, a.theta_end_rad});
  append_to_catalogue(run_dir, entry);
}

void show_status(const LiveStatus& st) {
  static const bool tty = isatty(STDERR_FILENO) != 0;
  static auto last_line = std::chrono::steady_clock::time_point{};
  const double progress = st.board.value(wire_key::calibration_progress, -1.0);
  const std::string line = fmt::format(
      "{}t {:6.2f}/{:.2f} s  V {:5.1f} V  angle {:8.4f} mrad  residual {:6.1f} urad  sensor {} "
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

/// The run's config: the files and --set (with the drive keys given as
/// options) and the board's address; `asked`: what the command asks for.
config::ConfigFile run_config(const RunOptions& o, const RunProgram& program, RunAsked& asked) {
  if (o.config.empty() && o.rig.empty()) {
    throw config::ConfigError("command line", "--config",
                              "required, or --rig ADDRESS (a board with its own config)");
  }
  config::ConfigFile config = config::load_config_file(
      o.config.empty() ? std::vector<std::string>{} : std::vector<std::string>{o.config}, o.sets,
      config::DriveOptions{o.V0, o.f, o.duration > 0.0 ? std::optional(o.duration) : std::nullopt,
                           o.reverse});
  asked = program.request ? program.request(config) : RunAsked{asked::Timed{}};
  if (!o.rig.empty()) config.host.board.address = o.rig;
  if (!o.axis.empty()) config.host.board.axis = o.axis;
  // The run's axis's own waveform and model, where the config describes it
  // ([axes.NAME] over the file's sections; the command's options applied).
  if (const config::AxisConfig* own = config.board.find_axis(config.host.board.axis)) {
    config.host.model = own->model;
  }
  return config;
}

/// The live view, bound before anything is created: a busy port is bad input.
std::unique_ptr<view::ViewServer> open_view(const RunOptions& o, const fs::path& dir,
                                            view::LiveFeed& live, const StopOnSignals& signals,
                                            std::atomic<bool>& estop_requested,
                                            const std::vector<std::string>& group,
                                            AxisStops& axis_stops) {
  auto server = std::make_unique<view::ViewServer>(
      view::ViewOptions{o.view_listen.empty() ? "127.0.0.1:8080" : o.view_listen,
                        fs::absolute(dir).parent_path().string(), o.control, o.allow_hosts},
      &live,
      view::ViewControls{[&signals, &group, &axis_stops](const nlohmann::json& body) {
                           // {"axis": NAME}: one axis of a group move; else the run.
                           const auto axis =
                               body.is_object() ? body.find(wire_key::axis) : body.end();
                           if (axis == body.end() || axis->is_null()) {
                             signals.request_stop();
                           } else if (axis->is_string() &&
                                      std::find(group.begin(), group.end(), *axis) != group.end()) {
                             axis_stops.request(axis->get<std::string>());
                           } else {
                             throw std::invalid_argument(fmt::format(
                                 "stop: axis: {} is not an axis of this group move (its axes: {})",
                                 axis->dump(), fmt::join(group, ", ")));
                           }
                           return nlohmann::json::object();
                         },
                         [&estop_requested](const nlohmann::json&) {
                           estop_requested.store(true);
                           return nlohmann::json::object();
                         },
                         {},
                         {}});
  write_out(stderr, server->banner() + "\n");
  return server;
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
                      {"lease_s", st.lease_s},
                      {"log_error", st.log_error}});
  };
}

int run(const RunOptions& o, const RunProgram& program) {
  // From here on every stopping signal ends the run through the ramp; one
  // that comes during set-up stops it before the amplifier is enabled.
  const StopOnSignals signals;
  RunAsked asked;
  config::ConfigFile config = run_config(o, program, asked);
  const fs::path dir = choose_run_dir(o.out);
  RunBoard board;
  connect(board, config, asked);
  // What the view's controls reach, declared before the server: it stops
  // (its threads joined) before they go.
  std::atomic<bool> estop_requested{false};
  AxisStops axis_stops;
  std::optional<view::LiveFeed> live;
  std::unique_ptr<view::ViewServer> server;
  if (o.view) {
    live.emplace(20.0, 3.0 / config.host.model.drive.f);
    server = open_view(o, dir, *live, signals, estop_requested, board.axes, axis_stops);
  }
  const std::string utc_start = utc_stamp("%Y-%m-%dT%H:%M:%SZ");
  const fs::path log_path = dir / "run.h5";
  RunLog log = create_log(dir, config, board, utc_start);
  // The live view takes the collector's rows, not the log's: a log that
  // fails leaves the view going to the run's end.
  std::function<void(const log_schema::AxesRows&)> to_view;
  if (live) {
    live->set_axes(board.axes);
    to_view = [&live](const log_schema::AxesRows& rows) { live->add(rows); };
  }
  RunSummary summary =
      drive(board, config, log, signals.flag(), status_reporter(o, live ? &*live : nullptr),
            estop_requested, to_view, axis_stops);
  if (!o.json && isatty(STDERR_FILENO)) write_out(stderr, "\n");
  // The run's JSON (a move's account is its axes').
  const auto result_json = [&] { return summary_json(summary, dir, log_path, signals.received()); };
  nlohmann::json logged = result_json();
  if (summary.board.calibration.present) logged["calibration"] = calibration_result(summary.board);
  finish_log(log, summary, logged);
  try {
    append_catalogue(dir, utc_start, config, summary);
  } catch (const std::exception& e) {
    write_out(stderr, fmt::format("piezo: warning: catalogue not updated: {}\n", e.what()));
  }
  // The open pages take the run's last columns and how it ended (within two
  // stream periods) before the view goes with this function; a page that
  // does not read keeps the process at most a second.
  if (live) {
    live->finish(summary.status());
    server->let_pages_take_the_end(std::chrono::seconds(1));
  }
  // Again: finishing the log may have failed the run.
  return program.report(FinishedRun{o, summary, config, dir, log_path, signals.received(),
                                    result_json(), *board.client, board.local != nullptr});
}

}  // namespace

void add_run_options(CLI::App& cmd, RunOptions& o, const std::string& config_doc,
                     const std::string& rig_doc, const std::string& json_doc) {
  add_config_option(cmd, o.config, config_doc)->check(CLI::ExistingFile);
  cmd.add_option("--set", o.sets, "Override a config key: SECTION.KEY=VALUE");
  add_out_option(cmd, o.out, "Run directory (default: runs/<UTC time>)");
  cmd.add_option("--rig", o.rig, rig_doc);
  cmd.add_option("--axis", o.axis,
                 "The board's axis to drive, by name (default: [rig] axis; required on a board "
                 "of several axes)");
  add_json_flag(cmd, o.json, json_doc);
  cmd.add_option("--view", o.view_listen,
                 "Serve the live page to a browser on HOST:PORT (default 127.0.0.1:8080)")
      ->expected(0, 1);
  cmd.add_flag("--control", o.control,
               "Let the live page stop and e-stop the run (with the token it prints)");
  cmd.add_option("--allow-host", o.allow_hosts,
                 "A host name the live page may be reached by besides its address and the "
                 "loopback names (repeatable)");
}

CommandRunner run_command(CLI::App* cmd, std::shared_ptr<RunOptions> o, RunProgram program) {
  return [cmd, o = std::move(o), program = std::move(program)]() {
    o->view = cmd->count("--view") > 0;
    return run(*o, program);
  };
}

}  // namespace piezo::host
