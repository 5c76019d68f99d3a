#include "piezo/hal/comedi/comedi_device.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include "piezo/config/config_error.hpp"

namespace piezo::hal::comedi {
namespace {

const char* type_name(int type) {
  switch (type) {
    case COMEDI_SUBD_AI:
      return "analog input";
    case COMEDI_SUBD_AO:
      return "analog output";
    case COMEDI_SUBD_DI:
      return "digital input";
    case COMEDI_SUBD_DO:
      return "digital output";
    case COMEDI_SUBD_DIO:
      return "digital I/O";
    case COMEDI_SUBD_COUNTER:
      return "counter";
    case COMEDI_SUBD_TIMER:
      return "timer";
    case COMEDI_SUBD_UNUSED:
      return "unused";
    default:
      return "other";
  }
}

}  // namespace

std::string ComediDevice::last_error(const std::string& call) {
  return call + ": " + comedi_strerror(comedi_errno());
}

ComediDevice::ComediDevice(const std::string& path) : path_(path), dev_(comedi_open(path.c_str())) {
  if (dev_ == nullptr) {
    throw std::runtime_error(
        fmt::format("comedi {}: cannot open: {} (is the driver loaded, and "
                    "may this user open it? see docs/hardware.md)",
                    path, comedi_strerror(comedi_errno())));
  }
}

ComediDevice::~ComediDevice() {
  if (dev_ != nullptr) comedi_close(dev_);
}

bool ComediDevice::reopen() {
  if (dev_ != nullptr) comedi_close(dev_);
  dev_ = comedi_open(path_.c_str());
  return dev_ != nullptr;
}

unsigned ComediDevice::checked_subdevice(const ChannelAddress& a, const SubdeviceKind& kind,
                                         const AddressKeys& keys) const {
  const std::string subdevice_key = keys.section + "." + keys.subdevice;
  const std::string channel_key = keys.section + "." + keys.channel;
  const int n = comedi_get_n_subdevices(dev_);
  // The ones that would do, for the message.
  std::string fitting;
  for (int s = 0; s < n; ++s) {
    const int flags = comedi_get_subdevice_flags(dev_, static_cast<unsigned>(s));
    if (kind.has_type(comedi_get_subdevice_type(dev_, static_cast<unsigned>(s))) && flags >= 0 &&
        (flags & kind.flags) == kind.flags) {
      fitting += (fitting.empty() ? "" : ", ") + std::to_string(s);
    }
  }
  const std::string allowed = fitting.empty() ? "none on this card" : fitting;
  int s = a.subdevice;
  if (s < 0) {
    if (fitting.empty()) {
      throw config::ConfigError(
          path_, subdevice_key,
          fmt::format("the card has no {} (allowed: {})", kind.what, allowed));
    }
    s = std::stoi(fitting.substr(0, fitting.find(',')));
  }
  if (s >= n) {
    throw config::ConfigError(
        path_, subdevice_key,
        fmt::format("{} is not a subdevice of this card ({} subdevices); allowed: {}", s, n,
                    allowed));
  }
  const auto sub = static_cast<unsigned>(s);
  const int type = comedi_get_subdevice_type(dev_, sub);
  const int flags = comedi_get_subdevice_flags(dev_, sub);
  if (!kind.has_type(type) || flags < 0 || (flags & kind.flags) != kind.flags) {
    throw config::ConfigError(
        path_, subdevice_key,
        fmt::format("subdevice {} is a{} {}, not {}; allowed: {}", s,
                    type == COMEDI_SUBD_AI || type == COMEDI_SUBD_AO ? "n" : "", type_name(type),
                    kind.what, allowed));
  }
  const int channels = comedi_get_n_channels(dev_, sub);
  if (a.channel < 0 || a.channel >= channels) {
    throw config::ConfigError(path_, channel_key,
                              fmt::format("{} is not a channel of subdevice {} ({} channels); "
                                          "allowed: 0..{}",
                                          a.channel, s, channels, channels - 1));
  }
  if (kind.analog()) {
    const int ranges = comedi_get_n_ranges(dev_, sub, static_cast<unsigned>(a.channel));
    if (a.range < 0 || a.range >= ranges) {
      throw config::ConfigError(path_, keys.section + "." + keys.range,
                                fmt::format("{} is not a range of subdevice {} channel {} ({} "
                                            "ranges, `piezo sensor list` shows them); allowed: "
                                            "0..{}",
                                            a.range, s, a.channel, ranges, ranges - 1));
    }
  }
  return sub;
}

comedi_polynomial_t ComediDevice::converter(unsigned subdevice, unsigned channel, unsigned range,
                                            comedi_conversion_direction direction) const {
  comedi_polynomial_t p{};
  const int flags = comedi_get_subdevice_flags(dev_, subdevice);
  if (flags >= 0 && (flags & SDF_SOFT_CALIBRATED) != 0) {
    // Calibrated in software: the coefficients comedi_soft_calibrate stored.
    char* file = comedi_get_default_calibration_path(dev_);
    comedi_calibration_t* calibration = file ? comedi_parse_calibration_file(file) : nullptr;
    const bool ok =
        calibration != nullptr &&
        comedi_get_softcal_converter(subdevice, channel, range, direction, calibration, &p) == 0;
    if (calibration) comedi_cleanup_calibration(calibration);
    const std::string where = file ? file : "(no path)";
    std::free(file);
    if (!ok) {
      throw std::runtime_error(
          fmt::format("comedi {}: the card is calibrated in software but "
                      "{} has no calibration for subdevice {} channel {} "
                      "range {}: run comedi_soft_calibrate first",
                      path_, where, subdevice, channel, range));
    }
    return p;
  }
  if (comedi_get_hardcal_converter(dev_, subdevice, channel, range, direction, &p) != 0) {
    throw std::runtime_error(
        fmt::format("comedi {}: {}", path_, last_error("comedi_get_hardcal_converter")));
  }
  return p;
}

std::string ComediDevice::describe() const {
  std::string out = fmt::format("{}: {} ({})\n", path_, comedi_get_board_name(dev_),
                                comedi_get_driver_name(dev_));
  const int n = comedi_get_n_subdevices(dev_);
  for (int s = 0; s < n; ++s) {
    const auto sub = static_cast<unsigned>(s);
    const int type = comedi_get_subdevice_type(dev_, sub);
    const int flags = comedi_get_subdevice_flags(dev_, sub);
    if (type == COMEDI_SUBD_UNUSED) continue;
    const bool clocked = flags >= 0 && (flags & (SDF_CMD_READ | SDF_CMD_WRITE)) != 0;
    out += fmt::format("  subdevice {}: {}, {} channels, {} bits{}\n", s, type_name(type),
                       comedi_get_n_channels(dev_, sub),
                       static_cast<int>(std::log2(double(comedi_get_maxdata(dev_, sub, 0)) + 1)),
                       clocked ? ", clocked (commands)" : "");
    if (type != COMEDI_SUBD_AI && type != COMEDI_SUBD_AO) continue;
    const int ranges = comedi_get_n_ranges(dev_, sub, 0);
    for (int r = 0; r < ranges; ++r) {
      const comedi_range* range = comedi_get_range(dev_, sub, 0, static_cast<unsigned>(r));
      if (range == nullptr) continue;
      out += fmt::format("    range {}: [{:g}, {:g}] {}\n", r, range->min, range->max,
                         range->unit == UNIT_volt ? "V"
                         : range->unit == UNIT_mA ? "mA"
                                                  : "");
    }
  }
  return out;
}

}  // namespace piezo::hal::comedi
