#pragma once
/// @file
/// The displacement sensor as a DAQ card's analog input, clocked by the card
/// at the sensor rate: the analog output a laser triangulation sensor
/// offers (a voltage span, or 4-20 mA across a shunt) mapped onto its
/// measuring range, through the card's own calibration. A reading at either
/// rail or outside the span is out_of_range; no sample within the timeout
/// (a stalled acquisition) is a timeout, which the supervisor counts.

#include <memory>
#include <vector>

#include "piezo/hal/clock.hpp"
#include "piezo/hal/comedi/comedi_device.hpp"
#include "piezo/hal/comedi/daq_arithmetic.hpp"
#include "piezo/hal/displacement_sensor.hpp"

namespace piezo::hal::comedi {

struct AnalogInputSettings {
  ChannelAddress input;  ///< subdevice -1: the card's first clocked analog input
  double rate_hz = 1000.0;
  AnalogSpan span;
  double timeout_s = 0.05;  ///< no sample for this long: a stalled acquisition
};

class ComediAnalogInput final : public DisplacementSensor {
 public:
  /// Opens and checks the card (ConfigError naming the key for a wrong
  /// subdevice, channel or range; std::runtime_error when it cannot clock
  /// the input at the rate). The stream starts with the first read.
  ComediAnalogInput(const AnalogInputSettings& settings, const Clock& clock);
  ~ComediAnalogInput() override;

  /// The newest sample the card took (older ones the loop did not ask for
  /// are skipped), as a displacement.
  [[nodiscard]] DisplacementReading read() override;
  /// The card: its inputs are read in turn (one acquisition per subdevice).
  [[nodiscard]] std::string shared_line() const override { return "comedi " + settings_.input.device; }

  /// The newest sample's volts at the card's input, for the wiring check.
  [[nodiscard]] double last_volts() const { return last_volts_; }

 private:
  [[nodiscard]] bool start_stream();
  void stop_stream();
  /// Reads what the card has; the newest sample's raw value, or -1 (none
  /// within the timeout), -2 (the stream stopped).
  [[nodiscard]] long newest_raw();

  AnalogInputSettings settings_;
  const Clock& clock_;
  ComediDevice device_;
  unsigned subdevice_ = 0;
  unsigned chanlist_ = 0;
  unsigned convert_ = TRIG_NOW;  ///< the conversion trigger the card takes
  comedi_polynomial_t to_volts_{};
  unsigned maxdata_ = 0;
  std::size_t sample_bytes_ = 2;
  std::vector<unsigned char> scratch_;  ///< a tenth of a second of samples, allocated once
  bool streaming_ = false;
  double last_volts_ = 0.0;
};

}  // namespace piezo::hal::comedi
