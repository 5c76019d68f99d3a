#include "piezo/hal/comedi/comedi_analog_output.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "piezo/hal/comedi/daq_arithmetic.hpp"

namespace piezo::hal::comedi {
namespace {

constexpr SubdeviceKind kReadbackInput{COMEDI_SUBD_AI, 0, "an analog input"};

}  // namespace

ComediAnalogOutput::ComediAnalogOutput(const AnalogOutputSettings& s)
    : settings_(s), scan_(OutputScan::of(s.output, s.rate_hz, s.preload_s)) {
  ComediDevice& card = scan_->device();
  const unsigned subdevice = card.checked_subdevice(s.output, kClockedOutput, {"drive.comedi"});
  const auto channel = static_cast<unsigned>(s.output.channel);
  const auto range = static_cast<unsigned>(s.output.range);
  to_raw_ = card.converter(subdevice, channel, range, COMEDI_FROM_PHYSICAL);
  maxdata_ = comedi_get_maxdata(card.get(), subdevice, channel);
  const comedi_range* r = comedi_get_range(card.get(), subdevice, channel, range);
  range_min_V_ = r->min;
  range_max_V_ = r->max;
  if (s.readback.channel >= 0) {
    ChannelAddress readback = s.readback;
    readback_subdevice_ = card.checked_subdevice(
        readback, kReadbackInput,
        {"drive.comedi", "readback_subdevice", "readback_channel", "readback_range"});
    readback_to_volts_ =
        card.converter(readback_subdevice_, static_cast<unsigned>(readback.channel),
                       static_cast<unsigned>(readback.range), COMEDI_TO_PHYSICAL);
    has_readback_ = true;
  }
  id_ = scan_->join(channel, range, raw_for(0.0));
  if (write_now(0.0) != Status::ok) {
    scan_->leave(id_);
    throw std::runtime_error(fmt::format("comedi {}: cannot write 0 V to subdevice {} channel {}",
                                         card.path(), subdevice, channel));
  }
}

ComediAnalogOutput::~ComediAnalogOutput() {
  (void)write_now(0.0);
  scan_->leave(id_);
}

std::uint32_t ComediAnalogOutput::raw_for(double volts) const {
  // Amplifier output volts to the card's, clamped to its code range: a value
  // past it must never wrap to a small one.
  const double card_V = std::clamp(volts / settings_.amplifier_gain, range_min_V_, range_max_V_);
  const double raw = std::round(comedi_from_physical(card_V, &to_raw_));
  return static_cast<std::uint32_t>(std::clamp(raw, 0.0, static_cast<double>(maxdata_)));
}

DriveLimits ComediAnalogOutput::limits() const {
  return {range_min_V_ * settings_.amplifier_gain, range_max_V_ * settings_.amplifier_gain};
}

double ComediAnalogOutput::output_latency_s() const { return scan_->latency_s(); }

Status ComediAnalogOutput::write(double volts) {
  const Status written = scan_->write(id_, raw_for(volts));
  if (written == Status::ok) acknowledged_V_ = volts;
  return written;
}

Status ComediAnalogOutput::end_tick() { return scan_->end_tick(); }

Status ComediAnalogOutput::write_now(double volts) {
  if (scan_->write_now(id_, raw_for(volts)) != Status::ok) return Status::io_error;
  if (has_readback_) {
    ComediDevice& card = scan_->device();
    lsampl_t raw = 0;
    if (comedi_data_read(card.get(), readback_subdevice_,
                         static_cast<unsigned>(settings_.readback.channel),
                         static_cast<unsigned>(settings_.readback.range), AREF_GROUND, &raw) < 0) {
      return Status::io_error;
    }
    const double read_V = comedi_to_physical(raw, &readback_to_volts_) * settings_.amplifier_gain;
    acknowledged_V_ = read_V;
    return std::abs(read_V - volts) <= settings_.readback_tolerance_V * settings_.amplifier_gain
               ? Status::ok
               : Status::out_of_range;
  }
  acknowledged_V_ = volts;
  return Status::ok;
}

}  // namespace piezo::hal::comedi
