#pragma once
/// @file
/// The drive as a DAQ card's analog output, clocked by the card: a Comedi
/// command at the drive rate whose buffer the drive loop keeps `preload`
/// samples deep, so that the sawtooth's timing is the card's crystal, not the
/// loop's wake-ups. A stop cancels the stream and writes 0 V at once; an
/// analog input wired to the output, where the config names one, confirms it.

#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "piezo/hal/comedi/comedi_device.hpp"
#include "piezo/hal/comedi/daq_arithmetic.hpp"
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
  /// clock at the rate) and writes 0 V; the stream starts with the first write.
  explicit ComediAnalogOutput(const AnalogOutputSettings& settings);
  ~ComediAnalogOutput() override;

  /// Queues `volts` (at the amplifier's output) behind the preload: one
  /// sample per call (the drive loop writes every deadline's value, a late
  /// loop's in a burst), sent to the card a millisecond's worth at a time.
  Status write(double volts) override;
  /// Cancels the stream and writes `volts` at once; with a read-back input,
  /// ok only once that input reads it.
  Status write_now(double volts) override;
  [[nodiscard]] double acknowledged_V() const override { return acknowledged_V_; }
  /// With a read-back input configured: a stop's 0 V is measured there.
  [[nodiscard]] bool reads_back() const override { return has_readback_; }
  [[nodiscard]] DriveLimits limits() const override;
  [[nodiscard]] double output_latency_s() const override;

  /// Streams that ran dry (each a missed deadline, the stream restarted at
  /// the value due then) and samples queued in all, for checks.
  [[nodiscard]] std::uint64_t underruns() const { return underruns_; }
  [[nodiscard]] std::uint64_t samples_queued() const { return samples_queued_; }
  /// Samples still waiting in the card's buffer (negative: the stream stopped).
  [[nodiscard]] long queued_now() const;

 private:
  [[nodiscard]] std::uint32_t raw_for(double volts) const;
  [[nodiscard]] Status start_stream(std::uint32_t raw);
  /// The handle's set-up: this subdevice for write(), writes that never block.
  [[nodiscard]] bool prepare_handle();
  /// The card opened again by its path (a handle that no longer reaches it).
  [[nodiscard]] bool reopen();
  void store(std::size_t index, std::uint32_t raw);
  [[nodiscard]] bool send(std::size_t samples);
  /// Sends the pending batch, corrected for drift; restarts a stream that ran dry.
  [[nodiscard]] Status flush(std::uint32_t raw);
  void stop_stream();

  AnalogOutputSettings settings_;
  ComediDevice device_;
  unsigned subdevice_ = 0;
  unsigned readback_subdevice_ = 0;
  bool has_readback_ = false;
  comedi_polynomial_t to_raw_{};
  comedi_polynomial_t readback_to_volts_{};
  std::uint32_t maxdata_ = 0;
  std::size_t sample_bytes_ = 2;
  std::size_t preload_ = 2;
  std::size_t batch_ = 1;    ///< samples sent to the card at once
  std::size_t pending_ = 0;  ///< written, not yet sent
  double range_min_V_ = 0.0, range_max_V_ = 0.0;
  std::vector<unsigned char> scratch_;  ///< a preload of samples, allocated once
  DriftKeeper drift_{2, 1};
  bool streaming_ = false;
  std::uint64_t underruns_ = 0;
  std::uint64_t samples_queued_ = 0;
  double acknowledged_V_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace piezo::hal::comedi
