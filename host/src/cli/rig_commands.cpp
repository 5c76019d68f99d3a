// The entry of the rig commands' module (libpiezo_rig_commands.so): the
// commands that drive, watch or stand in for a rig, with what they bring
// (ZeroMQ, GPIO, Comedi, Modbus, the web view). `piezo` loads it only for a
// command line that is not one of the model's own (main.cpp), so that a
// model command starts as a small program.

#include "commands.hpp"

namespace {
using namespace piezo::host;
constexpr NamedCommand kRigCommands[] = {
    {"run", add_run_command},
    {"step", add_step_command},
    {"move", add_move_command},
    {"scan", add_scan_command},
    {"calibrate", add_calibrate_command},
    {"view", add_view_command},
    {"sensor", add_sensor_command},
    {"rig-sim", add_rig_sim_command},
    {"hello", add_board_commands},
    {"status", add_board_commands},
    {"zero", add_board_commands},
    {"stop", add_board_commands},
    {"estop", add_board_commands},
    {"reset-fault", add_board_commands},
};
}  // namespace

/// Adds the rig command `named`, or all of them when `named` is none of
/// theirs (`piezo --help`, a misspelt command).
extern "C" __attribute__((visibility("default"))) void piezo_add_rig_commands(CLI::App& app,
                                                                              Commands& commands,
                                                                              const char* named) {
  add_named_or_all(kRigCommands, named, app, commands);
}
