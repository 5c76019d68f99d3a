// `piezo run`: drive the rig (real or simulated) for a duration and log it.

#include <fmt/format.h>
#include <unistd.h>

#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "config_error.hpp"
#include "parameters_json.hpp"
#include "rig.hpp"
#include "run_config.hpp"
#include "run_log.hpp"
#include "run_session.hpp"
#include "signals.hpp"

namespace piezo::host {
namespace {

namespace fs = std::filesystem;

constexpr int kExitFailed = 1;
constexpr int kExitInterrupted = 130;  // the shell's code for SIGINT

struct RunOptions {
  std::vector<std::string> config;
  std::vector<std::string> sets;
  double duration = 0.0;  // 0: the config's [run] duration_s
  std::string out;
  bool json = false;
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

/// The run directory: --out, or runs/<UTC time>. It must not hold a run already.
fs::path choose_run_dir(const std::string& out) {
  const fs::path dir = out.empty() ? fs::path("runs") / utc_stamp("%Y%m%dT%H%M%SZ") : fs::path(out);
  if (fs::exists(dir) && !(fs::is_directory(dir) && fs::is_empty(dir))) {
    throw ConfigError("--out", dir.string(), "exists and is not an empty directory");
  }
  return dir;
}

nlohmann::json loop_json(const LoopSummary& s) {
  return {{"samples", s.samples},
          {"overruns", s.overruns},
          {"missed_cycles", s.missed_cycles},
          {"dropped", s.dropped},
          {"errors", s.errors},
          {"errors_by_class", s.errors_by_class},
          {"period_error_us",
           {{"p50", s.p50_us}, {"p99", s.p99_us}, {"max", s.max_us}, {"mean", s.mean_us}}}};
}

nlohmann::json summary_json(const RunSummary& s, const fs::path& dir, const fs::path& log) {
  nlohmann::json observer = nullptr;
  if (s.observer) {
    observer = {{"samples", s.observer->samples},
                {"residual_rms_rad", s.observer->residual_rms_rad},
                {"open_loop_rms_rad", s.observer->open_loop_rms_rad}};
  }
  return {{"status", s.status()},
          {"observer", observer},
          {"stop_cause", std::string(firmware::to_string(s.cause))},
          {"run_dir", dir.string()},
          {"log", log.string()},
          {"drive", loop_json(s.drive)},
          {"sensor", loop_json(s.sensor)},
          {"theta_end_rad", s.theta_end_rad},
          {"t_end_s", s.t_end_s},
          {"mean_velocity_rad_s", s.mean_velocity_rad_s},
          {"realtime", s.realtime_notes}};
}

void print_summary(const RunSummary& s, const fs::path& log) {
  fmt::print("run {} ({})\n", s.status(), firmware::to_string(s.cause));
  fmt::print("  angle      {:.4f} mrad at t = {:.3f} s, mean velocity {:.4f} mrad/s\n",
             1e3 * s.theta_end_rad, s.t_end_s, 1e3 * s.mean_velocity_rad_s);
  for (const auto& [name, l] : {std::pair{"drive", &s.drive}, std::pair{"sensor", &s.sensor}}) {
    fmt::print(
        "  {:<7}    {} samples, {} errors, {} dropped, {} overruns ({} missed); "
        "period error p50 {:.0f} us, p99 {:.0f} us, max {:.1f} us\n",
        name, l->samples, l->errors, l->dropped, l->overruns, l->missed_cycles, l->p50_us,
        l->p99_us, l->max_us);
  }
  if (s.observer) {
    fmt::print(
        "  observer   residual {:.2f} urad rms (open-loop model {:.2f} urad rms) over {} samples\n",
        1e6 * s.observer->residual_rms_rad, 1e6 * s.observer->open_loop_rms_rad,
        s.observer->samples);
  }
  for (const auto& note : s.realtime_notes) fmt::print("  real time  {}\n", note);
  fmt::print("  log        {}\n", log.string());
}

void append_catalogue(const fs::path& run_dir, const std::string& utc_start,
                      const RunConfig& config, const RunSummary& s) {
  const fs::path catalogue = fs::absolute(run_dir).parent_path() / "catalogue.csv";
  const bool fresh = !fs::exists(catalogue);
  std::ofstream out(catalogue, std::ios::app);
  if (fresh) out << "run_dir,utc_start,status,stop_cause,config,t_end_s,theta_end_rad\n";
  out << fmt::format("{},{},{},{},{},{:.6g},{:.9g}\n", run_dir.filename().string(), utc_start,
                     s.status(), firmware::to_string(s.cause), config.source, s.t_end_s,
                     s.theta_end_rad);
}

void show_status(const LiveStatus& st) {
  static const bool tty = isatty(STDERR_FILENO) != 0;
  static auto last_line = std::chrono::steady_clock::time_point{};
  const std::string line = fmt::format(
      "t {:6.2f}/{:.2f} s  V {:5.1f} V  theta {:8.4f} mrad  residual {:6.1f} urad  sensor {} ({} "
      "errors)  overruns {}",
      st.t_s, st.duration_s, st.V, 1e3 * st.theta_rad, 1e6 * st.residual_rad, st.sensor_samples,
      st.sensor_errors, st.overruns);
  if (tty) {
    fmt::print(stderr, "\r{}\x1b[K", line);
  } else if (std::chrono::steady_clock::now() - last_line > std::chrono::seconds(1)) {
    fmt::print(stderr, "{}\n", line);
    last_line = std::chrono::steady_clock::now();
  }
}

int run(const RunOptions& o) {
  std::vector<std::string> sets = o.sets;
  if (o.duration > 0.0) sets.push_back(fmt::format("run.duration_s={}", o.duration));
  const RunConfig config = load_run_config(o.config, sets);
  Rig rig = build_rig(config);
  const fs::path dir = choose_run_dir(o.out);

  // Everything is checked: only now does the run leave traces.
  const StopOnSignals signals;
  fs::create_directories(dir);
  std::ofstream(dir / "config.toml") << config.text;
  const std::string utc_start = utc_stamp("%Y-%m-%dT%H:%M:%SZ");
  const fs::path log_path = dir / "run.h5";
  RunLog log = RunLog::create(
      log_path.string(),
      {{"config", config.text},
       {"config_source", config.source},
       {"model_parameters", to_json(config.model).dump()},
       {"plant_parameters", to_json(model::Parameters{config.model.drive, config.plant}).dump()},
       {"version", PIEZO_VERSION},
       {"utc_start", utc_start},
       {"host", host_name()},
       {"clock", config.run.clock},
       {"drive_latency_s", fmt::format("{:.9g}", rig.drive->output_latency_s())},
       {"time_origin", "seconds from the run's start (first drive deadline)"},
       {"theta", "(displacement - first good displacement) / sensor.r2_m"}});

  RunSummary summary;
  try {
    summary = execute_run(config, rig, log, signals.flag(),
                          o.json ? std::function<void(const LiveStatus&)>{} : show_status);
  } catch (...) {
    log.close("failed");
    throw;
  }
  if (!o.json && isatty(STDERR_FILENO)) fmt::print(stderr, "\n");

  log.write("/timing/drive_period_error_us", summary.drive.histogram);
  log.write("/timing/acquire_period_error_us", summary.sensor.histogram);
  const nlohmann::json result = summary_json(summary, dir, log_path);
  log.set_attribute("summary", result.dump());
  log.set_attribute("realtime", fmt::format("{}", fmt::join(summary.realtime_notes, "; ")));
  log.set_attribute("stop_cause", std::string(firmware::to_string(summary.cause)));
  log.close(summary.status());
  append_catalogue(dir, utc_start, config, summary);

  if (o.json) {
    std::cout << result.dump() << "\n";
  } else {
    print_summary(summary, log_path);
  }
  switch (summary.cause) {
    case firmware::StopCause::completed:
      return 0;
    case firmware::StopCause::interrupted:
      return kExitInterrupted;
    default:
      return kExitFailed;
  }
}

}  // namespace

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
  cmd->add_flag("--json", o->json, "Print one JSON summary on stdout");
  return [o, cmd]() { return cmd->parsed() ? run(*o) : -1; };
}

}  // namespace piezo::host
