// piezo recover RUN_DIR: makes a crashed run's log whole again from its
// journal (run_journal.hpp).

#include <fmt/format.h>

#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "commands.hpp"
#include "run_journal.hpp"

namespace piezo::host {
namespace {

struct RecoverOptions {
  std::string run_dir;
  bool json = false;
};

int run(const RecoverOptions& o) {
  const Recovery r = recover_run(o.run_dir);
  if (o.json) {
    std::cout << nlohmann::json{{"run_dir", o.run_dir},
                                {"rebuilt", r.rebuilt},
                                {"status", r.status},
                                {"drive_samples", r.drive_rows},
                                {"sensor_samples", r.sensor_rows},
                                {"observer_samples", r.observer_rows},
                                {"journal_blocks", r.blocks},
                                {"torn_bytes", r.torn_bytes},
                                {"damaged", r.damaged}}
                     .dump()
              << "\n";
  } else if (r.rebuilt) {
    fmt::print(
        "{}: run.h5 rebuilt from run.journal ({} blocks, {} drive, {} sensor samples{}), "
        "marked recovered{}\n",
        o.run_dir, r.blocks, r.drive_rows, r.sensor_rows,
        r.torn_bytes > 0 ? fmt::format("; {} torn bytes at its end dropped", r.torn_bytes)
                         : std::string(),
        r.damaged.empty() ? std::string() : "; the old file kept as run.h5.damaged");
  } else {
    fmt::print("{}: run.h5 is readable ({}); nothing to recover\n", o.run_dir, r.status);
  }
  return 0;
}

}  // namespace

CommandRunner add_recover_command(CLI::App& app) {
  auto o = std::make_shared<RecoverOptions>();
  CLI::App* cmd = app.add_subcommand(
      "recover", "Rebuild a crashed run's run.h5 from its journal, marked recovered");
  cmd->add_option("RUN_DIR", o->run_dir, "Run directory (holds run.h5 and run.journal)")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_flag("--json", o->json, "Print one JSON object on stdout");
  return [o, cmd]() { return cmd->parsed() ? run(*o) : -1; };
}

}  // namespace piezo::host
