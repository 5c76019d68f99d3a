#include "piezo/hal/comedi/comedi_analog_input.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <poll.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace piezo::hal::comedi {
namespace {

constexpr SubdeviceKind kClockedInput{COMEDI_SUBD_AI, SDF_CMD_READ, "a clocked analog input"};

/// One channel a period until cancelled; `convert` TRIG_NOW where the card
/// takes it (one channel needs no conversion clock), else TRIG_TIMER.
comedi_cmd stream_command(unsigned subdevice, unsigned* chanlist, unsigned period_ns,
                          unsigned convert) {
  comedi_cmd cmd{};
  cmd.subdev = subdevice;
  cmd.start_src = TRIG_NOW;
  cmd.scan_begin_src = TRIG_TIMER;
  cmd.scan_begin_arg = period_ns;
  cmd.convert_src = convert;
  cmd.convert_arg = 0;  // as fast as the card converts
  cmd.scan_end_src = TRIG_COUNT;
  cmd.scan_end_arg = 1;
  cmd.stop_src = TRIG_NONE;
  cmd.chanlist = chanlist;
  cmd.chanlist_len = 1;
  return cmd;
}

}  // namespace

ComediAnalogInput::ComediAnalogInput(const AnalogInputSettings& s, const Clock& clock)
    : settings_(s), clock_(clock), device_(s.input.device) {
  subdevice_ = device_.checked_subdevice(s.input, kClockedInput, {"sensor.comedi"});
  const auto channel = static_cast<unsigned>(s.input.channel);
  const auto range = static_cast<unsigned>(s.input.range);
  to_volts_ = device_.converter(subdevice_, channel, range, COMEDI_TO_PHYSICAL);
  maxdata_ = comedi_get_maxdata(device_.get(), subdevice_, channel);
  sample_bytes_ = (comedi_get_subdevice_flags(device_.get(), subdevice_) & SDF_LSAMPL) != 0
                      ? sizeof(lsampl_t)
                      : sizeof(sampl_t);
  scratch_.resize(std::max<std::size_t>(64, static_cast<std::size_t>(s.rate_hz / 10)) *
                  sample_bytes_);
  chanlist_ = CR_PACK(channel, range, AREF_GROUND);
  const auto period_ns = static_cast<unsigned>(std::lround(1e9 / s.rate_hz));
  comedi_cmd cmd = stream_command(subdevice_, &chanlist_, period_ns, TRIG_NOW);
  int tested = comedi_command_test(device_.get(), &cmd);
  if (tested == 1 || tested == 2) {
    convert_ = TRIG_TIMER;
    cmd = stream_command(subdevice_, &chanlist_, period_ns, convert_);
    tested = comedi_command_test(device_.get(), &cmd);
  }
  if (tested >= 3) tested = comedi_command_test(device_.get(), &cmd);  // arguments adjusted
  if (tested != 0 || cmd.scan_begin_arg != period_ns) {
    throw std::runtime_error(fmt::format(
        "comedi {}: subdevice {} cannot clock its input at sensor.rate_hz = {:g} Hz (the "
        "driver offers {:g} Hz; command test stage {})",
        device_.path(), subdevice_, s.rate_hz,
        cmd.scan_begin_arg > 0 ? 1e9 / cmd.scan_begin_arg : 0.0, tested));
  }
  if (comedi_get_read_subdevice(device_.get()) != static_cast<int>(subdevice_) &&
      comedi_set_read_subdevice(device_.get(), subdevice_) < 0) {
    throw std::runtime_error(fmt::format("comedi {}: {}", device_.path(),
                                         ComediDevice::last_error("comedi_set_read_subdevice")));
  }
  const int fd = comedi_fileno(device_.get());
  fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
}

ComediAnalogInput::~ComediAnalogInput() {
  stop_stream();
}

bool ComediAnalogInput::start_stream() {
  const auto period_ns = static_cast<unsigned>(std::lround(1e9 / settings_.rate_hz));
  comedi_cmd cmd = stream_command(subdevice_, &chanlist_, period_ns, convert_);
  (void)comedi_command_test(device_.get(), &cmd);  // the convert clock's argument
  streaming_ = comedi_command(device_.get(), &cmd) >= 0;
  return streaming_;
}

void ComediAnalogInput::stop_stream() {
  if (streaming_) comedi_cancel(device_.get(), subdevice_);
  streaming_ = false;
}

long ComediAnalogInput::newest_raw() {
  const int fd = comedi_fileno(device_.get());
  pollfd p{fd, POLLIN, 0};
  const int wait_ms = static_cast<int>(std::ceil(settings_.timeout_s * 1e3));
  const int ready = ::poll(&p, 1, wait_ms);
  if (ready <= 0) return -1;
  long newest = -1;
  for (;;) {
    const ssize_t n = ::read(fd, scratch_.data(), scratch_.size());
    if (n < 0) {
      if (errno == EAGAIN) break;  // everything the card had
      return -2;                   // overflowed or stopped
    }
    if (n == 0) return newest >= 0 ? newest : -2;  // the stream ended
    const std::size_t last = (static_cast<std::size_t>(n) / sample_bytes_ - 1) * sample_bytes_;
    if (sample_bytes_ == sizeof(lsampl_t)) {
      lsampl_t v;
      std::memcpy(&v, scratch_.data() + last, sizeof v);
      newest = static_cast<long>(v);
    } else {
      sampl_t v;
      std::memcpy(&v, scratch_.data() + last, sizeof v);
      newest = static_cast<long>(v);
    }
    if (static_cast<std::size_t>(n) < scratch_.size()) break;
  }
  return newest;
}

DisplacementReading ComediAnalogInput::read() {
  DisplacementReading r;
  r.t_request = clock_.now();
  if (!streaming_ && !start_stream()) {
    r.status = Status::io_error;
    r.t_response = clock_.now();
    return r;
  }
  long raw = newest_raw();
  if (raw == -2) {
    // The buffer overflowed while no one read (between runs): start afresh.
    stop_stream();
    raw = start_stream() ? newest_raw() : -2;
  }
  r.t_response = clock_.now();
  if (raw < 0) {
    r.status = raw == -1 ? Status::timeout : Status::io_error;
    return r;
  }
  last_volts_ = comedi_to_physical(static_cast<lsampl_t>(raw), &to_volts_);
  if (at_rail(static_cast<unsigned>(raw), maxdata_) || !settings_.span.admits(last_volts_)) {
    r.status = Status::out_of_range;
    return r;
  }
  r.displacement_m = settings_.span.distance_m(last_volts_);
  return r;
}

}  // namespace piezo::hal::comedi
