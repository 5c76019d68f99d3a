#pragma once
// The config's sections, each read by its owner's reader: the board's
// (board_sections.cpp: its devices, lines, safety and daemon), the host's
// (host_sections.cpp: its runs, moves, observer and the board it talks to)
// and the simulated rig's (rig_sim_sections.cpp: its plant and its Modbus
// server's faults). config_file.cpp reads a file's sections through them,
// in one pass (one file may hold all three).

#include "config_file.hpp"
#include "piezo/config/section_reader.hpp"

namespace piezo::config::sections {

/// How a pass of the readers goes: every backend's section (reading a file,
/// declaring the keys), or the chosen backend's alone (the effective config).
enum class Backends_read { every, chosen };

// The board's (board_sections.cpp). `rate_hz`: where the board's loop rate
// goes ([drive] and [sensor]); null in an axis's own sections, which may not
// name one (one tick drives every axis).
void read_drive(SectionReader r, DriveSettings& d, model::Parameters& waveform, Backends_read which,
                double* rate_hz);
void read_sensor(SectionReader r, SensorSettings& s, Backends_read which, double* rate_hz);
void read_lines(SectionReader r, LinesSettings& l, Backends_read which);
/// [safety]'s keys that each axis has (the caller finishes the section).
void read_safety(SectionReader& r, firmware::SafetySettings& s);
void read_daemon(SectionReader r, DaemonSettings& d);

// The host's (host_sections.cpp).
/// [run]: the host's keys and the board's share the section.
void read_run(SectionReader r, RunSettings& run, BoardRunSettings& board);
/// [move]: the defaults of `piezo move`'s options.
void read_move(SectionReader r, firmware::MoveRequest& m);
void read_observer(SectionReader r, ObserverSettings& o);
void read_board_address(SectionReader r, BoardAddress& a);

// The simulated rig's (rig_sim_sections.cpp).
void read_rig_sim(SectionReader r, hal::sim::ModbusDeviceFaults& f, hal::sim::TcpLimits& tcp);
/// [plant]: the simulated motor's keys, collected apart (NaN marks absent),
/// its end stop and its crosstalk from the other axes.
void read_plant(SectionReader r, model::MotorParameters& plant_keys, AxisConfig& axis);

}  // namespace piezo::config::sections
