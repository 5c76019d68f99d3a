#include "piezo/hal/comedi/comedi_backends.hpp"

#include <fmt/format.h>

#include "piezo/config/config_error.hpp"

namespace piezo::hal::comedi {
namespace {

using config::ConfigError;

/// device, subdevice, channel and range: where a signal is on the card.
void read_address(config::SectionReader& r, ChannelAddress& a, const std::string& prefix = "") {
  if (prefix.empty()) r.text("device", a.device);
  r.integer(prefix + "subdevice", a.subdevice, -1, 255);
  r.integer(prefix + "channel", a.channel, prefix.empty() ? 0 : -1, 1023);
  r.integer(prefix + "range", a.range, 0, 255);
}

/// A card's analog channel as a resource two axes must not share.
std::string analog_channel(const ChannelAddress& a, const char* kind) {
  return fmt::format("comedi {} analog {} {} (subdevice {})", a.device, kind, a.channel,
                     a.subdevice);
}

}  // namespace

std::string ComediDriveBackend::describe() const {
  return fmt::format("comedi {} channel {}", settings_.output.device, settings_.output.channel);
}

std::vector<Claim> ComediDriveBackend::claims() const {
  std::vector<Claim> out{{analog_channel(settings_.output, "output"), "drive.comedi.channel"}};
  if (settings_.readback.channel >= 0) {
    const ChannelAddress input{
        settings_.readback.device.empty() ? settings_.output.device : settings_.readback.device,
        settings_.readback.subdevice, settings_.readback.channel, 0};
    out.push_back({analog_channel(input, "input"), "drive.comedi.readback_channel"});
  }
  return out;
}

std::string ComediDriveBackend::inventory() const {
  return ComediDevice(settings_.output.device).describe();
}

void ComediDriveBackend::read(config::SectionReader& r) {
  read_address(r, settings_.output);
  r.number("preload_s", settings_.preload_s, {0.0005, 0.1}, "s");
  read_address(r, settings_.readback, "readback_");
  r.number("readback_tolerance_V", settings_.readback_tolerance_V, {0.0, 10.0, true}, "V");
}

AnalogOutputSettings ComediDriveBackend::settings(const DriveCommon& common) const {
  AnalogOutputSettings s = settings_;
  s.rate_hz = common.rate_hz;
  s.amplifier_gain = common.amplifier_gain;
  s.readback.device = s.output.device;
  return s;
}

std::shared_ptr<Drive> ComediDriveBackend::open(const DriveCommon& common, OpenContext&) const {
  return std::make_shared<ComediAnalogOutput>(settings(common));
}

std::string ComediSensorBackend::describe() const {
  return fmt::format("comedi {} channel {}", settings_.input.device, settings_.input.channel);
}

std::vector<Claim> ComediSensorBackend::claims() const {
  return {{analog_channel(settings_.input, "input"), "sensor.comedi.channel"}};
}

std::string ComediSensorBackend::inventory() const {
  return ComediDevice(settings_.input.device).describe();
}

void ComediSensorBackend::read(config::SectionReader& r) {
  read_address(r, settings_.input);
  auto& span = settings_.span;
  r.number("span_start_V", span.start_V, {-100.0, 100.0}, "V");
  r.number("span_end_V", span.end_V, {-100.0, 100.0}, "V");
  r.number("distance_start_m", span.start_m, {-10.0, 10.0}, "m");
  r.number("distance_end_m", span.end_m, {-10.0, 10.0}, "m");
  r.number("timeout_s", settings_.timeout_s, {0.0, 10.0, true}, "s");
}

void ComediSensorBackend::check(const SensorCommon&, bool, const SourceOf& source) const {
  const auto& span = settings_.span;
  if (span.start_V == span.end_V) {
    throw ConfigError(
        source("sensor.comedi.span_end_V"), "sensor.comedi.span_end_V",
        fmt::format("{:g} V equals span_start_V: the span must have two ends", span.end_V));
  }
  if (span.start_m == span.end_m) {
    throw ConfigError(
        source("sensor.comedi.distance_end_m"), "sensor.comedi.distance_end_m",
        fmt::format("{:g} m equals distance_start_m: the range must have two ends", span.end_m));
  }
}

AnalogInputSettings ComediSensorBackend::settings(const SensorCommon& common) const {
  AnalogInputSettings s = settings_;
  s.rate_hz = common.rate_hz;
  return s;
}

std::shared_ptr<DisplacementSensor> ComediSensorBackend::open(const SensorCommon& common,
                                                              OpenContext& context) const {
  return std::make_shared<ComediAnalogInput>(settings(common), context.clock);
}

std::string ComediLinesBackend::describe() const {
  return fmt::format("comedi {} enable channel {}", settings_.device, settings_.enable_channel);
}

std::string ComediLinesBackend::inventory() const {
  return ComediDevice(settings_.device).describe();
}

void ComediLinesBackend::read(config::SectionReader& r) {
  auto& s = settings_;
  r.text("device", s.device);
  r.integer("subdevice", s.subdevice, -1, 255);
  // Below 32: the outputs are set together by one bit-field call.
  r.integer("enable_channel", s.enable_channel, 0, 31);
  r.integer("sync_channel", s.sync_channel, -1, 31);
  r.integer("estop_subdevice", s.estop_subdevice, -1, 255);
  r.integer("estop_channel", s.estop_channel, -1, 1023);
  r.flag("enable_active_low", s.lines.enable_active_low);
  r.flag("sync_active_low", s.lines.sync_active_low);
  r.flag("estop_active_low", s.lines.estop_active_low);
  r.integer_list("trigger_channels", s.trigger_channels, -1, 31);
  r.flag("trigger_active_low", s.trigger_active_low);
}

std::shared_ptr<DigitalLines> ComediLinesBackend::open(const LinesCommon&, OpenContext&) const {
  return open_digital_lines(settings_);
}

}  // namespace piezo::hal::comedi
