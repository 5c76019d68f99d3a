#pragma once
/// @file
/// The drive as a channel of a DAQ card's analog output, clocked by the
/// card: one scan of every axis's channel on the card (OutputScan) at the
/// drive rate, whose buffer the drive loop keeps `preload` scans deep, so
/// that the sawtooth's timing is the card's crystal, not the loop's wake-ups.
/// A stop puts 0 V out on its channel at once (the other axes' channels go
/// on); an analog input wired to the output, where the config names one,
/// confirms it.

#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "piezo/hal/comedi/comedi_device.hpp"
#include "piezo/hal/comedi/comedi_output_scan.hpp"
#include "piezo/hal/drive.hpp"

namespace piezo::hal::comedi {

struct AnalogOutputSettings {
  ChannelAddress output;  ///< subdevice -1: the card's first clocked analog output
  double rate_hz = 10'000.0;
  /// How far the queue runs ahead of the card's clock: more than the
  /// driver's transfer granularity (a DMA block; comedi_test's timer tick).
  double preload_s = 0.01;
  double amplifier_gain = 20.0;  ///< piezo volts per volt at the card's output
  /// An analog input wired to the output (same card), read to confirm a
  /// stop's 0 V; channel < 0: none, and 0 V is the driver's word only.
  ChannelAddress readback{"", -1, -1, 0};
  double readback_tolerance_V = 0.05;  ///< at the card's output
};

class ComediAnalogOutput final : public Drive {
 public:
  /// Opens and checks the card (ConfigError naming the key for a wrong
  /// subdevice, channel or range; std::runtime_error when the card cannot
  /// clock the scan at the rate), joins the card's scan and writes 0 V; the
  /// stream starts with the first tick's values.
  explicit ComediAnalogOutput(const AnalogOutputSettings& settings);
  ~ComediAnalogOutput() override;

  /// Queues `volts` (at the amplifier's output) behind the preload: one
  /// sample per call (the drive loop writes every deadline's value, a late
  /// loop's in a burst), its scan sent to the card a millisecond's worth at
  /// a time once every channel of it has its value or the tick ends.
  Status write(double volts) override;
  Status end_tick() override;
  /// Writes `volts` on this channel at once, ahead of what is queued (the
  /// other channels' queue is sent again); with a read-back input, ok only
  /// once that input reads it.
  Status write_now(double volts) override;
  [[nodiscard]] double acknowledged_V() const override { return acknowledged_V_; }
  /// With a read-back input configured: a stop's 0 V is measured there.
  [[nodiscard]] bool reads_back() const override { return has_readback_; }
  [[nodiscard]] DriveLimits limits() const override;
  [[nodiscard]] double output_latency_s() const override;

  /// Streams that ran dry (each a missed deadline, the stream restarted at
  /// the values due then) and samples of this channel queued in all (one a
  /// scan), for checks.
  [[nodiscard]] std::uint64_t underruns() const { return scan_->underruns(); }
  [[nodiscard]] std::uint64_t samples_queued() const { return scan_->scans_queued(); }
  /// Samples still waiting in the card's buffer (negative: the stream stopped).
  [[nodiscard]] long queued_now() const { return scan_->queued_now(); }

 private:
  [[nodiscard]] std::uint32_t raw_for(double volts) const;

  AnalogOutputSettings settings_;
  std::shared_ptr<OutputScan> scan_;
  std::size_t id_ = 0;  ///< this channel in the scan
  unsigned readback_subdevice_ = 0;
  bool has_readback_ = false;
  comedi_polynomial_t to_raw_{};
  comedi_polynomial_t readback_to_volts_{};
  std::uint32_t maxdata_ = 0;
  double range_min_V_ = 0.0, range_max_V_ = 0.0;
  double acknowledged_V_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace piezo::hal::comedi
