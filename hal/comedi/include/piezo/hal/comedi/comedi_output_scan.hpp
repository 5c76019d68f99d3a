#pragma once
/// @file
/// A card's clocked analog output as one Comedi command: a scan of every
/// channel a drive of the board has joined, clocked at the drive rate, its
/// buffer kept `preload` scans deep. A card runs one command per subdevice,
/// so the axes of a board on one card share this scan; each axis's drive
/// (ComediAnalogOutput) writes its value into the tick's scan, which goes to
/// the card once every channel has its value or the tick ends. A stop of one
/// channel puts its 0 V out at once and sends the others' queued values
/// again: they go on as if nothing happened.

#include <cstdint>
#include <memory>
#include <vector>

#include "piezo/hal/comedi/comedi_device.hpp"
#include "piezo/hal/comedi/daq_arithmetic.hpp"
#include "piezo/hal/status.hpp"

namespace piezo::hal::comedi {

inline constexpr SubdeviceKind kClockedOutput{COMEDI_SUBD_AO, SDF_CMD_WRITE,
                                              "a clocked analog output"};

class OutputScan {
 public:
  /// The scan of `output.device`'s clocked output, opened by its first
  /// channel and shared by the next (std::runtime_error when they ask
  /// another subdevice, rate or preload of it).
  static std::shared_ptr<OutputScan> of(const ChannelAddress& output, double rate_hz,
                                        double preload_s);

  /// Opens the card, checks `output` (ConfigError naming drive.comedi's key)
  /// and that the card clocks one channel at `rate_hz`.
  OutputScan(const ChannelAddress& output, double rate_hz, double preload_s);
  ~OutputScan();
  OutputScan(const OutputScan&) = delete;
  OutputScan& operator=(const OutputScan&) = delete;

  /// Adds a channel (held at `raw`) to the scan and returns its id;
  /// std::runtime_error when the card cannot clock the scan at the rate.
  /// A running stream stops: the next tick starts it with every channel.
  std::size_t join(unsigned channel, unsigned range, std::uint32_t raw);
  void leave(std::size_t id);

  /// The tick's value of one channel; the scan goes to the card when every
  /// channel has its value (the status of that), else at end_tick().
  Status write(std::size_t id, std::uint32_t raw);
  /// Sends the tick's scan if a channel wrote into it (the others keep
  /// their last values); the status of the last scan sent.
  Status end_tick();
  /// Puts `raw` out on one channel at once, ahead of anything queued, and
  /// holds it there: the stream is cancelled, the channel written, and the
  /// scans still queued for the other channels sent again.
  Status write_now(std::size_t id, std::uint32_t raw);

  [[nodiscard]] ComediDevice& device() { return device_; }
  [[nodiscard]] unsigned subdevice() const { return subdevice_; }
  [[nodiscard]] double rate_hz() const { return rate_hz_; }
  [[nodiscard]] double preload_s() const { return preload_s_; }
  /// From a write to its scan leaving the card [s].
  [[nodiscard]] double latency_s() const;
  [[nodiscard]] std::uint64_t underruns() const { return underruns_; }
  [[nodiscard]] std::uint64_t scans_queued() const { return scans_queued_; }
  /// Scans still waiting in the card's buffer (negative: the stream stopped).
  [[nodiscard]] long queued_now() const;

 private:
  struct Channel {
    std::size_t id;
    unsigned packed;       ///< CR_PACK of channel, range, ground
    bool written = false;  ///< has its value in this tick's scan
    bool active = false;   ///< writes the stream (not stopped since its last write)
  };

  [[nodiscard]] std::size_t index_of(std::size_t id) const;
  [[nodiscard]] bool prepare_handle();
  [[nodiscard]] bool reopen();
  [[nodiscard]] Status commit();
  [[nodiscard]] Status start_stream(std::size_t preloaded);
  [[nodiscard]] Status flush();
  /// The tick's scan into the send buffer at `slot`, and into the history.
  void store(std::size_t slot);
  /// One scan's values into the send buffer at `slot`, as the card takes them.
  void encode(std::size_t slot, const std::uint32_t* values);
  [[nodiscard]] bool send(std::size_t scans);
  void stop_stream();
  /// Restarts the stream with the scans still queued before a stop.
  void resend(std::size_t scans);

  ComediDevice device_;
  unsigned subdevice_ = 0;
  double rate_hz_;
  double preload_s_;
  std::size_t sample_bytes_ = 2;
  std::size_t preload_ = 2;  ///< scans
  std::size_t batch_ = 1;    ///< scans sent to the card at once
  std::size_t pending_ = 0;  ///< scans stored, not yet sent
  std::size_t next_id_ = 0;
  std::vector<Channel> channels_;
  std::vector<unsigned> chanlist_;
  std::vector<std::uint32_t> scan_;     ///< this tick's value of each channel
  std::vector<std::uint32_t> history_;  ///< the last scans stored, a ring
  std::size_t history_scans_ = 0;       ///< ring capacity
  std::size_t stored_ = 0;              ///< scans ever stored: the ring's head
  std::vector<unsigned char> bytes_;    ///< samples as the card takes them
  DriftKeeper drift_{2, 1};
  bool streaming_ = false;
  Status last_ = Status::ok;
  std::uint64_t underruns_ = 0;
  std::uint64_t scans_queued_ = 0;
};

}  // namespace piezo::hal::comedi
