#pragma once
// What `piezo run`, `step`, `move` and `calibrate` share: the options that
// choose the config, the board and the run directory, and the run itself
// (connect, log, drive, finish the log). Each command is a slice of its
// own (cmd_run.cpp, cmd_step.cpp, cmd_move.cpp, cmd_calibrate.cpp) that
// adds its options, its request and its report: a `RunProgram`.

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "commands.hpp"
#include "config/config_file.hpp"
#include "run/board_client.hpp"
#include "run/board_request.hpp"
#include "run/run_session.hpp"

namespace piezo::host {

/// The options every run command takes, and the drive keys some of them
/// give as options (each one a config key, applied as a --set would be).
struct RunOptions {
  std::vector<std::string> config;
  std::vector<std::string> sets;
  std::string out;
  std::string rig;   ///< piezod's address; empty: the config's [rig] address, or in-process
  std::string axis;  ///< the board's axis to drive; empty: the config's [rig] axis
  bool json = false;
  double duration = 0.0;  ///< --duration; 0: the config's [run] duration_s
  bool reverse = false;   ///< --reverse: drive.direction = reverse
  std::optional<double> V0, f;
  /// --view [HOST:PORT]: the live page; --control lets it stop and e-stop.
  bool view = false;
  std::string view_listen;
  bool control = false;
  std::vector<std::string> allow_hosts;
};

/// What a finished run gives its command's report.
struct FinishedRun {
  const RunOptions& options;
  const RunSummary& summary;
  const config::ConfigFile& config;
  std::filesystem::path dir, log;
  std::string signal;     ///< the stopping signal received ("" none)
  nlohmann::json result;  ///< the run's JSON summary (a move's account under "move")
  BoardClient& board;
  bool local;  ///< the board is the one in this process
};

/// A command's own part of a run.
struct RunProgram {
  /// What it asks the board to run, once the files and --set are read (it
  /// may set [run] duration_s, the run's length; none: a timed run).
  std::function<RunAsked(config::ConfigFile&)> request;
  /// What it prints; returns the exit code.
  std::function<int(const FinishedRun&)> report;
};

/// --config (`config_doc`), --set, --out, --rig (`rig_doc`), --json
/// (`json_doc`), and the live view's --view, --control, --allow-host.
void add_run_options(CLI::App& cmd, RunOptions& o, const std::string& config_doc,
                     const std::string& rig_doc, const std::string& json_doc);
/// What `cmd` runs: `program`, with the options it was given.
[[nodiscard]] CommandRunner run_command(CLI::App* cmd, std::shared_ptr<RunOptions> o,
                                        RunProgram program);

/// The plain report: `result` (or the summary as text, with `steps` when
/// given), the output's state on stderr unless confirmed, the host's error.
int print_run(const FinishedRun& run, const nlohmann::json& result, const nlohmann::json& steps);
/// 0 completed, kExitInterrupted, else kExitFailed.
[[nodiscard]] int exit_code(const RunSummary& summary);
/// The summary as text: status, output, angle, loops, observer, log.
[[nodiscard]] std::string summary_text(const RunSummary& s, const std::filesystem::path& log,
                                       const std::string& signal, const nlohmann::json& steps);
/// How the output was left, in plain words.
[[nodiscard]] std::string output_line(const RunSummary& s);
/// Writes to a stream whose reader may be gone (a closed pipe, a closed
/// terminal): a failed write is dropped, the run goes on.
void write_out(std::FILE* stream, const std::string& text);

}  // namespace piezo::host
