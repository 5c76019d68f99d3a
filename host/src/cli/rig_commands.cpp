// The entry of the rig commands' module (libpiezo_rig_commands.so): the
// commands that drive, watch or stand in for a rig, with what they bring
// (ZeroMQ, GPIO, Comedi, Modbus, the web view). `piezo` loads it only for a
// command line that is not one of the model's own (main.cpp), so that a
// model command starts as a small program.

#include "commands.hpp"

extern "C" __attribute__((visibility("default"))) void piezo_add_rig_commands(
    CLI::App& app, piezo::host::Commands& commands) {
  using namespace piezo::host;
  for (const auto add : {add_run_command, add_step_command, add_move_command, add_scan_command,
                         add_calibrate_command, add_view_command, add_sensor_command,
                         add_rig_sim_command, add_board_commands}) {
    add(app, commands);
  }
}
