#include "piezo/hal/comedi/comedi_analog_output.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "piezo/hal/comedi/daq_arithmetic.hpp"

namespace piezo::hal::comedi {
namespace {

constexpr SubdeviceKind kClockedOutput{COMEDI_SUBD_AO, SDF_CMD_WRITE, "a clocked analog output"};
constexpr SubdeviceKind kInput{COMEDI_SUBD_AI, 0, "an analog input"};

/// A stream of one channel at one sample a period, started by the driver's
/// internal trigger (after the preload is in) and running until cancelled.
comedi_cmd stream_command(unsigned subdevice, unsigned* chanlist, unsigned period_ns) {
  comedi_cmd cmd{};
  cmd.subdev = subdevice;
  cmd.start_src = TRIG_INT;
  cmd.scan_begin_src = TRIG_TIMER;
  cmd.scan_begin_arg = period_ns;
  cmd.convert_src = TRIG_NOW;
  cmd.scan_end_src = TRIG_COUNT;
  cmd.scan_end_arg = 1;
  cmd.stop_src = TRIG_NONE;
  cmd.chanlist = chanlist;
  cmd.chanlist_len = 1;
  return cmd;
}

}  // namespace

ComediAnalogOutput::ComediAnalogOutput(const AnalogOutputSettings& s)
    : settings_(s), device_(s.output.device) {
  subdevice_ = device_.checked_subdevice(s.output, kClockedOutput, {"drive.comedi"});
  const auto channel = static_cast<unsigned>(s.output.channel);
  const auto range = static_cast<unsigned>(s.output.range);
  to_raw_ = device_.converter(subdevice_, channel, range, COMEDI_FROM_PHYSICAL);
  maxdata_ = comedi_get_maxdata(device_.get(), subdevice_, channel);
  const comedi_range* r = comedi_get_range(device_.get(), subdevice_, channel, range);
  range_min_V_ = r->min;
  range_max_V_ = r->max;
  sample_bytes_ = (comedi_get_subdevice_flags(device_.get(), subdevice_) & SDF_LSAMPL) != 0
                      ? sizeof(lsampl_t)
                      : sizeof(sampl_t);
  preload_ = preload_samples(s.preload_s, s.rate_hz);
  // Samples go to the card a millisecond's worth at a time (one system call,
  // not one a sample), within the preload.
  batch_ = std::clamp<std::size_t>(static_cast<std::size_t>(s.rate_hz / 1000.0), 1, preload_ / 2);
  // The level is judged over a tenth of a second: many of the card's bursts.
  drift_ = DriftKeeper(preload_, std::max<std::size_t>(1, std::size_t(s.rate_hz / 10) / batch_));
  scratch_.resize((preload_ + batch_ + 1) * sample_bytes_);
  if (s.readback.channel >= 0) {
    ChannelAddress readback = s.readback;
    readback_subdevice_ = device_.checked_subdevice(
        readback, kInput,
        {"drive.comedi", "readback_subdevice", "readback_channel", "readback_range"});
    readback_to_volts_ =
        device_.converter(readback_subdevice_, static_cast<unsigned>(readback.channel),
                          static_cast<unsigned>(readback.range), COMEDI_TO_PHYSICAL);
    has_readback_ = true;
  }
  // The card must clock the output at the drive rate exactly: a rate it
  // rounds would stretch every period.
  unsigned chanlist = CR_PACK(channel, range, AREF_GROUND);
  const auto period_ns = static_cast<unsigned>(std::lround(1e9 / s.rate_hz));
  comedi_cmd cmd = stream_command(subdevice_, &chanlist, period_ns);
  int tested = comedi_command_test(device_.get(), &cmd);
  if (tested == 4) tested = comedi_command_test(device_.get(), &cmd);  // arguments adjusted
  if (tested != 0 || cmd.scan_begin_arg != period_ns) {
    throw std::runtime_error(fmt::format(
        "comedi {}: subdevice {} cannot clock its output at drive.rate_hz = {:g} Hz (the "
        "driver offers {:g} Hz; command test stage {}); choose a rate the card divides exactly",
        device_.path(), subdevice_, s.rate_hz,
        cmd.scan_begin_arg > 0 ? 1e9 / cmd.scan_begin_arg : 0.0, tested));
  }
  if (!prepare_handle()) {
    throw std::runtime_error(fmt::format("comedi {}: {}", device_.path(),
                                         ComediDevice::last_error("comedi_set_write_subdevice")));
  }
  if (write_now(0.0) != Status::ok) {
    throw std::runtime_error(fmt::format("comedi {}: cannot write 0 V to subdevice {} channel {}",
                                         device_.path(), subdevice_, channel));
  }
}

ComediAnalogOutput::~ComediAnalogOutput() {
  (void)write_now(0.0);
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

double ComediAnalogOutput::output_latency_s() const {
  // A value waits for its batch, then behind the preload.
  return preload_latency_s(preload_ + batch_ - 1, settings_.rate_hz);
}

bool ComediAnalogOutput::prepare_handle() {
  if (comedi_get_write_subdevice(device_.get()) != static_cast<int>(subdevice_) &&
      comedi_set_write_subdevice(device_.get(), subdevice_) < 0) {
    return false;
  }
  // Writes never block the drive loop: a full buffer is the card's clock
  // running behind, handled in write().
  const int fd = comedi_fileno(device_.get());
  return fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK) == 0;
}

bool ComediAnalogOutput::reopen() {
  return device_.reopen() && prepare_handle();
}

long ComediAnalogOutput::queued_now() const {
  if (device_.get() == nullptr) return -1;
  const int bytes = comedi_get_buffer_contents(device_.get(), subdevice_);
  return bytes < 0 ? -1 : bytes / static_cast<long>(sample_bytes_);
}

void ComediAnalogOutput::store(std::size_t index, std::uint32_t raw) {
  unsigned char* at = scratch_.data() + index * sample_bytes_;
  if (sample_bytes_ == sizeof(lsampl_t)) {
    const lsampl_t v = raw;
    std::memcpy(at, &v, sizeof v);
  } else {
    const auto v = static_cast<sampl_t>(raw);
    std::memcpy(at, &v, sizeof v);
  }
}

bool ComediAnalogOutput::send(std::size_t samples) {
  if (device_.get() == nullptr) return false;
  const ssize_t n = ::write(comedi_fileno(device_.get()), scratch_.data(), samples * sample_bytes_);
  if (n < 0) return false;
  samples_queued_ += static_cast<std::uint64_t>(n) / sample_bytes_;
  return true;
}

Status ComediAnalogOutput::start_stream(std::uint32_t raw) {
  const auto channel = static_cast<unsigned>(settings_.output.channel);
  unsigned chanlist = CR_PACK(channel, static_cast<unsigned>(settings_.output.range), AREF_GROUND);
  const auto period_ns = static_cast<unsigned>(std::lround(1e9 / settings_.rate_hz));
  comedi_cmd cmd = stream_command(subdevice_, &chanlist, period_ns);
  if ((device_.get() == nullptr && !reopen()) || comedi_command(device_.get(), &cmd) < 0) {
    return Status::io_error;
  }
  // The preload goes in before the start, so the card never waits on the loop.
  for (std::size_t i = 0; i < preload_; ++i) store(i, raw);
  pending_ = 0;
  if (!send(preload_) || comedi_internal_trigger(device_.get(), subdevice_, 0) < 0) {
    comedi_cancel(device_.get(), subdevice_);
    return Status::io_error;
  }
  streaming_ = true;
  drift_.reset();
  return Status::ok;
}

void ComediAnalogOutput::stop_stream() {
  if (streaming_ && device_.get() != nullptr) comedi_cancel(device_.get(), subdevice_);
  streaming_ = false;
}

Status ComediAnalogOutput::write(double volts) {
  const std::uint32_t raw = raw_for(volts);
  if (!streaming_) {
    const Status started = start_stream(raw);
    if (started == Status::ok) acknowledged_V_ = volts;
    return started;
  }
  store(pending_++, raw);
  acknowledged_V_ = volts;
  return pending_ < batch_ ? Status::ok : flush(raw);
}

Status ComediAnalogOutput::flush(std::uint32_t raw) {
  const long queued = queued_now();
  if (queued >= 0) {
    // The drift keeper's correction: the last sample twice, or left out.
    const std::size_t copies = drift_.copies(static_cast<std::size_t>(queued));
    if (copies == 2) store(pending_++, raw);
    if (copies == 0) --pending_;
    const std::size_t samples = pending_;
    pending_ = 0;
    if (send(samples)) return Status::ok;
  }
  // The card ran out of samples and stopped its stream (EPIPE): a missed
  // deadline. It restarts at the value due now, never replaying old ones.
  pending_ = 0;
  if (queued < 0 || errno == EPIPE) {
    ++underruns_;
    stop_stream();
    (void)start_stream(raw);
    return Status::timeout;
  }
  return Status::io_error;
}

Status ComediAnalogOutput::write_now(double volts) {
  stop_stream();
  pending_ = 0;
  const auto channel = static_cast<unsigned>(settings_.output.channel);
  const auto write = [&] {
    return device_.get() != nullptr &&
           comedi_data_write(device_.get(), subdevice_, channel,
                             static_cast<unsigned>(settings_.output.range), AREF_GROUND,
                             raw_for(volts)) >= 0;
  };
  // A handle that no longer reaches the card (closed under the run, the card
  // re-enumerated) fails here: the stop's 0 V goes through the card opened
  // again by its path. Its stream ended with the handle that started it.
  if (!write() && !(reopen() && write())) return Status::io_error;
  if (has_readback_) {
    lsampl_t raw = 0;
    if (comedi_data_read(device_.get(), readback_subdevice_,
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
