// `piezo view`: the runs catalogue in a browser, and with --rig the live
// page of whatever that board runs (watched, not driven; with --control,
// e-stop and move-to). Serves until stopped. (`piezo run --view` serves the
// live page of the run it drives.)

#include <fmt/format.h>

#include <chrono>
#include <iostream>
#include <optional>
#include <thread>

#include "board_watch.hpp"
#include "commands.hpp"
#include "config/config_file.hpp"
#include "piezo/config/config_error.hpp"
#include "run/board_client.hpp"
#include "run/signals.hpp"
#include "view/live_feed.hpp"
#include "view/view_server.hpp"

namespace piezo::host {
namespace {

struct ViewCliOptions {
  view::ViewOptions server;
  std::string rig;
  std::vector<std::string> config;
};

int serve(const ViewCliOptions& o) {
  const StopOnSignals signals;
  if (o.rig.empty()) {
    if (o.server.control) {
      throw config::ConfigError("command line", "--control",
                                "needs --rig ADDRESS: there is nothing to control");
    }
    const view::ViewServer server(o.server, nullptr, {});
    std::cerr << server.banner() << "\n" << std::flush;
    while (!signals.flag().load()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    return 0;
  }
  // The host's view of the model and the sensor's radius: a config, or the defaults.
  config::ConfigFile config =
      o.config.empty() ? config::ConfigFile{} : config::load_config_file(o.config, {});
  config.host.board.address = o.rig;
  BoardClient client(config.host.board);
  const protocol::Hello hello = client.hello();
  for (const protocol::AxisInfo& axis : hello.axes) {
    if (const std::string note = sensor_geometry_note(config, axis); !note.empty()) {
      std::cerr << "piezo view: axis " << axis.name << ": " << note << "\n";
    }
  }
  view::LiveFeed feed(20.0, 0.3);
  BoardWatch watch(config, client, hello, feed);
  const view::ViewServer server(
      o.server, &feed,
      {[&watch](const nlohmann::json& body) { return watch.stop(body); },
       [&watch](const nlohmann::json&) { return watch.estop(); },
       [&watch](const nlohmann::json& body) { return watch.move_to(body); },
       [&watch](const nlohmann::json&) { return watch.dictionary(); }});
  std::cerr << server.banner() << "\n" << std::flush;
  while (!signals.flag().load()) watch.poll(std::chrono::milliseconds(50));
  return 0;
}

}  // namespace

void add_view_command(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<ViewCliOptions>();
  o->server.runs_dir = "runs";
  CLI::App* cmd = app.add_subcommand(
      "view", "Serve the runs catalogue, and a board's live runs, to a browser (Ctrl-C ends)");
  cmd->add_option("--runs", o->server.runs_dir, "Runs directory (its catalogue.csv)")
      ->capture_default_str();
  cmd->add_option("--listen", o->server.listen, "HOST:PORT to serve on (port 0: any free)")
      ->capture_default_str();
  cmd->add_option("--rig", o->rig, "piezod's address: show its runs live");
  add_config_option(*cmd, o->config,
                    "Config for the model and sensor radius (default: Table 1, r2 = 62 mm)");
  cmd->add_flag("--control", o->server.control,
                "With --rig: e-stop and move-to from the page, with the token it prints");
  cmd->add_option("--allow-host", o->server.allowed_hosts,
                  "A host name the pages may be reached by besides the address and the "
                  "loopback names (repeatable)");
  commands.add(cmd, [o] { return serve(*o); });
}

}  // namespace piezo::host
