#include "piezo/hal/gpiod/gpiod_backends.hpp"

#include <fmt/format.h>

#include "piezo/config/config_error.hpp"

namespace piezo::hal::gpiod {
namespace {

using config::ConfigError;

/// How the lines are labelled for other users of the chip (gpioinfo).
constexpr const char* kConsumer = "piezo";

}  // namespace

std::vector<Claim> ParallelDacBackend::claims() const {
  std::vector<Claim> out;
  for (const int offset : settings_.data_offsets) {
    out.push_back(
        {fmt::format("{} line {}", settings_.chip, offset), "drive.gpiod-dac.data_offsets"});
  }
  if (settings_.strobe_offset >= 0) {
    out.push_back({fmt::format("{} line {}", settings_.chip, settings_.strobe_offset),
                   "drive.gpiod-dac.strobe_offset"});
  }
  return out;
}

std::vector<MovedKey> ParallelDacBackend::moved_keys() const {
  return {{"gpio_chip", "drive.gpiod-dac.chip"},
          {"dac_data_offsets", "drive.gpiod-dac.data_offsets"},
          {"dac_strobe_offset", "drive.gpiod-dac.strobe_offset"},
          {"dac_data_active_low", "drive.gpiod-dac.data_active_low"},
          {"dac_strobe_active_low", "drive.gpiod-dac.strobe_active_low"},
          {"dac_full_scale_V", "drive.gpiod-dac.full_scale_V"}};
}

void ParallelDacBackend::read(config::SectionReader& r) {
  auto& s = settings_;
  r.text("chip", s.chip);
  r.integer_list("data_offsets", s.data_offsets, 0, 1023);
  r.integer("strobe_offset", s.strobe_offset, -1, 1023);
  r.flag("data_active_low", s.dac.data_active_low);
  r.flag("strobe_active_low", s.dac.strobe_active_low);
  r.number("full_scale_V", s.dac.full_scale_V, {0.0, 100.0, true}, "V");
}

void ParallelDacBackend::check(const DriveCommon&, bool chosen, const SourceOf& source) const {
  if (chosen && (settings_.data_offsets.empty() || settings_.data_offsets.size() > 32)) {
    throw ConfigError(source("drive.gpiod-dac.data_offsets"), "drive.gpiod-dac.data_offsets",
                      "gpiod-dac needs 1 to 32 data line offsets, least significant bit first");
  }
}

GpiodDacSettings ParallelDacBackend::settings(const DriveCommon& common) const {
  GpiodDacSettings s = settings_;
  s.dac.bits = static_cast<int>(s.data_offsets.size());
  s.dac.has_strobe = s.strobe_offset >= 0;
  s.dac.amplifier_gain = common.amplifier_gain;
  return s;
}

std::shared_ptr<Drive> ParallelDacBackend::open(const DriveCommon& common, OpenContext&) const {
  return std::make_shared<GpiodParallelDac>(settings(common), kConsumer);
}

std::vector<MovedKey> RigLinesBackend::moved_keys() const {
  return {{"chip", "lines.gpiod.chip"},
          {"enable_offset", "lines.gpiod.enable_offset"},
          {"sync_offset", "lines.gpiod.sync_offset"},
          {"estop_offset", "lines.gpiod.estop_offset"},
          {"enable_active_low", "lines.gpiod.enable_active_low"},
          {"sync_active_low", "lines.gpiod.sync_active_low"},
          {"estop_active_low", "lines.gpiod.estop_active_low"}};
}

void RigLinesBackend::read(config::SectionReader& r) {
  auto& g = settings_;
  r.text("chip", g.chip);
  r.integer("enable_offset", g.enable_offset, 0, 1023);
  r.integer("sync_offset", g.sync_offset, -1, 1023);
  r.integer("estop_offset", g.estop_offset, -1, 1023);
  r.flag("enable_active_low", g.gpio.enable_active_low);
  r.flag("sync_active_low", g.gpio.sync_active_low);
  r.flag("estop_active_low", g.gpio.estop_active_low);
  r.integer_list("trigger_offsets", g.trigger_offsets, -1, 1023);
  r.flag("trigger_active_low", g.triggers.active_low);
  g.gpio.has_sync = g.sync_offset >= 0;
  g.triggers.axes.clear();
  for (std::size_t axis = 0; axis < g.trigger_offsets.size(); ++axis) {
    if (g.trigger_offsets[axis] >= 0) g.triggers.axes.push_back(axis);
  }
}

void RigLinesBackend::check(const LinesCommon&, bool chosen, const SourceOf& source) const {
  if (chosen && settings_.enable_offset < 0) {
    throw ConfigError(source("lines.gpiod.enable_offset"), "lines.gpiod.enable_offset",
                      "missing: the gpiod lines need the amplifier-enable line offset");
  }
}

std::shared_ptr<DigitalLines> RigLinesBackend::open(const LinesCommon&, OpenContext&) const {
  return open_rig_lines(settings_, kConsumer);
}

}  // namespace piezo::hal::gpiod
