#pragma once
// The simulated rig as a Modbus device: the plant advances in real time,
// the sensor's registers report its rotor (the config's register map, by
// default the Baumer OM30 one), and a holding register takes the drive
// voltage the way an analog-output module would. A rig of several axes is
// one register space: each axis its own plant, its sensor's registers and
// its analog-output register, as a multi-channel module and sensors at
// their own addresses would be; their plants may shake each other
// (crosstalk, Plant::couple_to). Serves several TCP clients
// at once and/or RTU on a serial device or pseudo-terminal, with the faults
// of ModbusDeviceFaults injected. Like an I/O module, it has a communication
// watchdog (WAGO 750-352 style registers): armed, it sets the analog output
// to 0 when no restarting request came for its timeout.

#include <modbus.h>

#include <atomic>
#include <deque>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "piezo/hal/modbus/link.hpp"
#include "piezo/hal/modbus/register_map.hpp"
#include "piezo/hal/posix/monotonic_clock.hpp"
#include "piezo/hal/sim/plant.hpp"
#include "piezo/hal/sim/sim_sensor.hpp"
#include "piezo/model/parameters.hpp"

namespace piezo::hal::sim {

/// Faults the device can be told to show.
struct ModbusDeviceFaults {
  double response_delay_s = 0.0;
  double drop_probability = 0.0;       ///< requests left unanswered
  double exception_probability = 0.0;  ///< answered with exception 04 (server failure)
  double disconnect_at_s = std::numeric_limits<double>::infinity();  ///< closes every client
  /// One reply, the first after this time, comes late_reply_s late.
  double late_reply_at_s = std::numeric_limits<double>::infinity();
  double late_reply_s = 0.0;
  /// From hang_at_s on, for hang_for_s, requests get no reply (the module's
  /// watchdog still runs).
  double hang_at_s = std::numeric_limits<double>::infinity();
  double hang_for_s = 0.0;
  /// The times above count from the first non-zero analog-output write (a
  /// run's drive under way) instead of the device's start: a fault in the
  /// middle of a run, however long the run took to start.
  bool times_from_drive = false;
  /// The simulated module's communication watchdog, as on a WAGO 750-352:
  /// a holding register with the timeout in 100 ms units (0: off) and one
  /// with the mask of function codes that restart it (bit n-1: function n).
  int watchdog_time_address = 0x1000;
  int watchdog_mask_address = 0x1001;
  /// A hand on the rotors: holding register hand_address + i turns axis i's
  /// rotor by its value (a signed 16-bit count of microradians) when
  /// written, and reads 0 again. For tests of what the board sees at rest.
  int hand_address = 0x1010;
};

/// What the TCP side lets clients hold.
struct TcpLimits {
  /// Connections held at once; past it a new one is refused.
  int max_clients = 4096;
  /// A frame begun and not finished within this closes its connection.
  double frame_timeout_s = 0.5;
};

/// One axis of the device: its plant and the registers that reach it.
struct ModbusRigAxis {
  std::string name;  ///< for messages
  model::MotorParameters plant;
  AmplifierSettings amplifier;
  /// The sensor behind the registers; its latency, dropouts and stalls are
  /// off here: the link and the faults supply them.
  SimSensorSettings sensor;
  modbus::RegisterMap sensor_map;
  int ao_address = 0;  ///< the analog output's holding register
  double ao_counts_per_V = 1.0;
  /// The share of every other axis's stator stroke this axis's stator takes.
  double coupling = 0.0;
};

struct ModbusRigDeviceSettings {
  std::vector<ModbusRigAxis> axes = std::vector<ModbusRigAxis>(1);  ///< at least one
  modbus::LinkSettings serial;  ///< RTU: baud, parity, data and stop bits
  ModbusDeviceFaults faults;
  TcpLimits tcp;
};

class ModbusRigDevice {
 public:
  explicit ModbusRigDevice(const ModbusRigDeviceSettings& settings);
  ~ModbusRigDevice();
  ModbusRigDevice(const ModbusRigDevice&) = delete;
  ModbusRigDevice& operator=(const ModbusRigDevice&) = delete;

  /// Serves Modbus TCP on host:port until the process ends
  /// (modbus_tcp_server.cpp).
  void serve_tcp(const std::string& host, int port);
  /// Serves Modbus RTU on `device` at the sensor link's serial settings.
  void serve_rtu(const std::string& device);

  /// What the register map and the analog output are, for the start-up line.
  [[nodiscard]] std::string describe() const;

 private:
  enum class Fault { none, drop, exception };
  /// Brings the registers up to now and decides this request's fault.
  Fault prepare_reply_locked(int function);
  /// Applies a changed analog-output register to its axis's plant.
  void after_reply_locked();
  /// Zeroes the output once the armed watchdog has expired.
  void run_watchdog_locked(TimeNs now);
  /// Replies to one request, or not, as the faults decide.
  void answer(modbus_t* ctx, const std::uint8_t* query, int length);
  /// Runs the watchdog while no request comes.
  void idle();
  [[nodiscard]] bool disconnected() const;
  [[nodiscard]] bool hanging() const;
  /// Time on the faults' clock (see ModbusDeviceFaults::times_from_drive);
  /// -inf before its origin.
  [[nodiscard]] double fault_time_s() const;

  ModbusRigDeviceSettings settings_;
  posix::MonotonicClock clock_;
  TimeNs t_start_;
  std::atomic<TimeNs> fault_origin_;  ///< kNoOrigin until the first drive write, if it counts
  /// An axis as it runs: its plant, its sensor on it, its output's last counts.
  struct AxisState {
    AxisState(const ModbusRigAxis& axis, const SimSensorSettings& reading, Clock& clock, TimeNs t0)
        : plant(axis.plant, axis.amplifier, t0), sensor(reading, plant, clock, t0) {}
    Plant plant;
    SimSensor sensor;  ///< reads `plant`: never copied or moved (a deque holds them)
    std::uint16_t last_ao_counts = 0;
  };
  std::deque<AxisState> axes_;
  modbus_mapping_t* registers_;
  TimeNs watchdog_restarted_ = 0;
  bool late_reply_done_ = false;
  struct {
    std::uint64_t refused_frames = 0;   ///< malformed or unfinished frames (client closed)
    std::uint64_t refused_clients = 0;  ///< turned away at the cap
  } tcp_stats_;
  std::mutex mutex_;  // TCP and RTU may serve at once: registers and plant are shared
  std::mt19937_64 random_{7};
  std::uniform_real_distribution<double> uniform_{0.0, 1.0};
};

}  // namespace piezo::hal::sim
