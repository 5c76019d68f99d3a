// piezod: the firmware as its own program on the rig's board. Owns the
// hardware named in its config, keeps it within the board's limits by
// itself, and serves the protocol of docs/protocol.md.
//   piezod [--config FILE] [--set SECTION.KEY=VALUE]... [--listen ADDRESS] [--insecure]
//   piezod keygen --out DIR [--name NAME]
#include <CLI/CLI.hpp>
#include <csignal>
#include <iostream>

#include "client_authentication.hpp"
#include "config/config_file.hpp"
#include "config/device_inventory.hpp"
#include "daemon.hpp"
#include "piezo/config/config_error.hpp"
#include "service_manager.hpp"

namespace {

std::atomic<bool> g_stop{false};

extern "C" void on_signal(int /*signal*/) {
  g_stop.store(true);
}

void install_signal_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  for (int s : {SIGINT, SIGTERM, SIGHUP, SIGQUIT}) sigaction(s, &sa, nullptr);
  std::signal(SIGPIPE, SIG_IGN);
}

}  // namespace

int main(int argc, char** argv) {
  install_signal_handlers();
  CLI::App app{"piezod: drive-and-acquire firmware of the piezo rig (docs/protocol.md)"};
  app.set_version_flag("--version",
                       std::string("piezod ") + PIEZO_VERSION + " (" + PIEZO_BUILD_INFO + ")");
  std::string config_path = "/etc/piezod.toml", listen;
  bool insecure = false;
  std::vector<std::string> sets;
  app.add_option("--config", config_path, "board config (backends, safety limits, listen address)");
  app.add_option("--listen", listen,
                 "command address, e.g. tcp://127.0.0.1:5555 or ipc:///run/piezod/cmd "
                 "(the stream listens next to it)");
  app.add_option("--set", sets, "override a config key: SECTION.KEY=VALUE");
  app.add_flag("--insecure", insecure, "allow plain text on a network address (logged)");
  auto* keygen = app.add_subcommand("keygen", "write a CURVE key pair (NAME.key, NAME.pub)");
  std::string key_dir = ".", key_name = "piezod";
  keygen->add_option("--out", key_dir, "directory")->required();
  keygen->add_option("--name", key_name, "file name without suffix");
  bool force = false;
  keygen->add_flag("--force", force, "replace an existing pair");
  auto* devices = app.add_subcommand(
      "devices", "list what the configured drive, sensor and lines offer, then exit");
  devices->fallthrough();  // --config and --set after it too
  CLI11_PARSE(app, argc, argv);

  try {
    if (*keygen) {
      piezo::daemon::write_keypair(piezo::daemon::generate_keypair(), key_dir, key_name, force);
      std::cout << "wrote " << key_dir << "/" << key_name << ".key (secret) and " << key_dir << "/"
                << key_name << ".pub\n";
      return 0;
    }
    auto board = piezo::config::load_config_file(config_path, sets).board;
    if (*devices) {
      std::cout << piezo::config::device_inventory(board, true);
      return 0;
    }
    if (insecure) board.daemon.insecure = true;
    zmq::context_t context;
    piezo::daemon::ServiceManager service;
    piezo::daemon::Daemon daemon(board, context, listen, std::cerr);
    service.ready();  // the hardware is open and the sockets bound
    daemon.serve(g_stop, [&service] { service.alive(); });
    service.stopping();
    return 0;
  } catch (const piezo::config::ConfigError& e) {
    std::cerr << "piezod: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "piezod: " << e.what() << "\n";
    return 1;
  }
}
