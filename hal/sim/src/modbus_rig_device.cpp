#include "piezo/hal/sim/modbus_rig_device.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <stdexcept>
#include <thread>

namespace piezo::hal::sim {
namespace {

constexpr TimeNs kNoOrigin = std::numeric_limits<TimeNs>::max();

SimSensorSettings instant_sensor(SimSensorSettings s) {
  s.latency_s = 0.0;  // the link supplies the latency
  s.dropout_probability = 0.0;
  s.stall_at_s = std::numeric_limits<double>::infinity();
  return s;
}

}  // namespace

ModbusRigDevice::ModbusRigDevice(const ModbusRigDeviceSettings& settings)
    : settings_(settings),
      t_start_(clock_.now()),
      fault_origin_(settings.faults.times_from_drive ? kNoOrigin : t_start_),
      registers_(modbus_mapping_new(0, 0, 65536, 65536)) {
  if (registers_ == nullptr) throw std::runtime_error("rig-sim: cannot allocate registers");
  for (const ModbusRigAxis& a : settings.axes) {
    AxisState& axis = axes_.emplace_back(a, instant_sensor(a.sensor), clock_, t_start_);
    axis.plant.set_enabled(t_start_, true);
  }
  // Each axis's stator takes its share of every other axis's stroke.
  for (std::size_t i = 0; i < axes_.size(); ++i) {
    if (settings.axes[i].coupling == 0.0) continue;
    for (std::size_t j = 0; j < axes_.size(); ++j) {
      if (j != i) axes_[j].plant.couple_to(axes_[i].plant, settings.axes[i].coupling);
    }
  }
  watchdog_restarted_ = t_start_;
}

ModbusRigDevice::~ModbusRigDevice() {
  modbus_mapping_free(registers_);
}

std::string ModbusRigDevice::describe() const {
  std::string out;
  for (std::size_t i = 0; i < settings_.axes.size(); ++i) {
    const ModbusRigAxis& a = settings_.axes[i];
    const auto& m = a.sensor_map;
    out += fmt::format(
        "{}sensor: {} register {} ({} words, unit {}), scale {:g} m per unit; analog output: "
        "holding register {} at {:g} counts/V",
        settings_.axes.size() == 1 ? "" : fmt::format("{}axis {}: ", i == 0 ? "" : "; ", a.name),
        m.function == modbus::Function::input ? "input" : "holding", m.address,
        modbus::word_count(m.type), m.unit_id, m.scale, a.ao_address, a.ao_counts_per_V);
  }
  return out;
}

double ModbusRigDevice::fault_time_s() const {
  const TimeNs origin = fault_origin_.load();
  if (origin == kNoOrigin) return -std::numeric_limits<double>::infinity();
  return to_seconds(clock_.now() - origin);
}

bool ModbusRigDevice::disconnected() const {
  return fault_time_s() >= settings_.faults.disconnect_at_s;
}

bool ModbusRigDevice::hanging() const {
  const auto& f = settings_.faults;
  const double t = fault_time_s();
  return t >= f.hang_at_s && t < f.hang_at_s + f.hang_for_s;
}

void ModbusRigDevice::run_watchdog_locked(TimeNs now) {
  const std::uint16_t tenths = registers_->tab_registers[settings_.faults.watchdog_time_address];
  if (tenths == 0 || now - watchdog_restarted_ < from_seconds(0.1 * tenths)) return;
  for (const ModbusRigAxis& a : settings_.axes) registers_->tab_registers[a.ao_address] = 0;
  after_reply_locked();
}

ModbusRigDevice::Fault ModbusRigDevice::prepare_reply_locked(int function) {
  const TimeNs now = clock_.now();
  run_watchdog_locked(now);
  const std::uint16_t mask = registers_->tab_registers[settings_.faults.watchdog_mask_address];
  if (function >= 1 && function <= 16 && (mask >> (function - 1) & 1U) != 0) {
    watchdog_restarted_ = now;
  }
  for (std::size_t i = 0; i < axes_.size(); ++i) {
    AxisState& axis = axes_[i];
    const ModbusRigAxis& a = settings_.axes[i];
    axis.plant.set_input(now, axis.last_ao_counts / a.ao_counts_per_V);
    const DisplacementReading r = axis.sensor.read();
    const auto& m = a.sensor_map;
    std::uint16_t* table = m.function == modbus::Function::input ? registers_->tab_input_registers
                                                                 : registers_->tab_registers;
    // The caller keeps address + words within the table.
    modbus::encode(m.type, m.order, (r.displacement_m - m.offset) / m.scale,
                   std::span<std::uint16_t>(table + m.address,
                                            static_cast<std::size_t>(modbus::word_count(m.type))));
  }
  const auto& f = settings_.faults;
  const double u = uniform_(random_);
  if (u < f.drop_probability) return Fault::drop;
  if (u < f.drop_probability + f.exception_probability) return Fault::exception;
  return Fault::none;
}

void ModbusRigDevice::after_reply_locked() {
  for (std::size_t i = 0; i < axes_.size(); ++i) {
    AxisState& axis = axes_[i];
    const ModbusRigAxis& a = settings_.axes[i];
    std::uint16_t& hand = registers_->tab_registers[settings_.faults.hand_address + i];
    if (hand != 0) {
      axis.plant.turn_by(clock_.now(), static_cast<std::int16_t>(hand) * 1e-6);
      hand = 0;
    }
    const std::uint16_t counts = registers_->tab_registers[a.ao_address];
    if (counts == axis.last_ao_counts) continue;
    axis.last_ao_counts = counts;
    if (counts != 0 && fault_origin_.load() == kNoOrigin) fault_origin_.store(clock_.now());
    axis.plant.set_input(clock_.now(), counts / a.ao_counts_per_V);
  }
}

void ModbusRigDevice::idle() {
  const std::lock_guard lock(mutex_);
  run_watchdog_locked(clock_.now());
}

void ModbusRigDevice::answer(modbus_t* ctx, const std::uint8_t* query, int length) {
  if (hanging()) return;  // the module takes the request and never answers
  const auto& f = settings_.faults;
  double delay_s = f.response_delay_s;
  {
    const std::lock_guard lock(mutex_);
    if (!late_reply_done_ && fault_time_s() >= f.late_reply_at_s) {
      late_reply_done_ = true;
      delay_s += f.late_reply_s;
    }
  }
  if (delay_s > 0.0) std::this_thread::sleep_for(std::chrono::duration<double>(delay_s));
  const int function = query[modbus_get_header_length(ctx)];
  // The registers are read by the reply and written by a write request:
  // both under the lock, as TCP and RTU may be served at once.
  const std::lock_guard lock(mutex_);
  const Fault fault = prepare_reply_locked(function);
  if (fault == Fault::exception) {
    modbus_reply_exception(ctx, query, MODBUS_EXCEPTION_SLAVE_OR_SERVER_FAILURE);
  } else if (fault == Fault::none) {
    modbus_reply(ctx, query, length, registers_);
    after_reply_locked();
  }
}

void ModbusRigDevice::serve_rtu(const std::string& device) {
  const auto& link = settings_.serial;
  modbus_t* ctx =
      modbus_new_rtu(device.c_str(), link.baud, link.parity, link.data_bits, link.stop_bits);
  // One unit on the line: the axes' registers are its (rig-sim's config check).
  if (ctx == nullptr || modbus_set_slave(ctx, settings_.axes.front().sensor_map.unit_id) != 0 ||
      modbus_connect(ctx) != 0) {
    const std::string why = modbus_strerror(errno);
    modbus_free(ctx);  // takes NULL
    throw std::runtime_error(fmt::format("rig-sim: cannot open {}: {}", device, why));
  }
  // Wake now and then without a request, for the watchdog.
  modbus_set_indication_timeout(ctx, 0, 20'000);
  std::uint8_t query[MODBUS_RTU_MAX_ADU_LENGTH];
  for (;;) {
    idle();
    const int length = modbus_receive(ctx, query);
    if (length <= 0) continue;     // a frame for another unit, or line noise
    if (disconnected()) continue;  // a dead line answers nothing
    answer(ctx, query, length);
  }
}

}  // namespace piezo::hal::sim
