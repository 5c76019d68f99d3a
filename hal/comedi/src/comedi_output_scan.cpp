#include "piezo/hal/comedi/comedi_output_scan.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>
#include <stdexcept>
#include <utility>

namespace piezo::hal::comedi {
namespace {

/// A stream of scans of `chanlist`, one a period, started by the driver's
/// internal trigger (after the preload is in) and running until cancelled.
comedi_cmd stream_command(unsigned subdevice, std::vector<unsigned>& chanlist,
                          unsigned period_ns) {
  comedi_cmd cmd{};
  cmd.subdev = subdevice;
  cmd.start_src = TRIG_INT;
  cmd.scan_begin_src = TRIG_TIMER;
  cmd.scan_begin_arg = period_ns;
  cmd.convert_src = TRIG_NOW;
  cmd.scan_end_src = TRIG_COUNT;
  cmd.scan_end_arg = static_cast<unsigned>(chanlist.size());
  cmd.stop_src = TRIG_NONE;
  cmd.chanlist = chanlist.data();
  cmd.chanlist_len = static_cast<unsigned>(chanlist.size());
  return cmd;
}

unsigned period_ns(double rate_hz) { return static_cast<unsigned>(std::lround(1e9 / rate_hz)); }

}  // namespace

std::shared_ptr<OutputScan> OutputScan::of(const ChannelAddress& output, double rate_hz,
                                           double preload_s) {
  // One scan per card and subdevice; the last channel's release closes it.
  static std::mutex scans_mutex;
  static std::multimap<std::string, std::weak_ptr<OutputScan>> scans;
  const std::lock_guard lock(scans_mutex);
  std::erase_if(scans, [](const auto& entry) { return entry.second.expired(); });
  const auto shared = [&](int subdevice) -> std::shared_ptr<OutputScan> {
    const auto [from, to] = scans.equal_range(output.device);
    for (auto it = from; it != to; ++it) {
      auto scan = it->second.lock();
      if (scan && (subdevice < 0 || static_cast<int>(scan->subdevice_) == subdevice)) return scan;
    }
    return nullptr;
  };
  auto scan = shared(output.subdevice);
  if (!scan) {
    scan = std::make_shared<OutputScan>(output, rate_hz, preload_s);
    // Asked as "the first clocked output" by one axis and by number by another.
    if (auto same = shared(static_cast<int>(scan->subdevice_))) {
      scan = same;
    } else {
      scans.emplace(output.device, scan);
    }
  }
  if (scan->rate_hz_ != rate_hz || scan->preload_s_ != preload_s) {
    throw std::runtime_error(fmt::format(
        "comedi {}: subdevice {} is one scan at {:g} Hz with a {:g} s preload; a channel asks "
        "{:g} Hz and {:g} s: every axis on it takes the same drive.rate_hz and "
        "drive.comedi.preload_s",
        output.device, scan->subdevice_, scan->rate_hz_, scan->preload_s_, rate_hz, preload_s));
  }
  return scan;
}

OutputScan::OutputScan(const ChannelAddress& output, double rate_hz, double preload_s)
    : device_(output.device), rate_hz_(rate_hz), preload_s_(preload_s) {
  subdevice_ = device_.checked_subdevice(output, kClockedOutput, {"drive.comedi"});
  sample_bytes_ = (comedi_get_subdevice_flags(device_.get(), subdevice_) & SDF_LSAMPL) != 0
                      ? sizeof(lsampl_t)
                      : sizeof(sampl_t);
  preload_ = preload_samples(preload_s, rate_hz);
  // Scans go to the card a millisecond's worth at a time (one system call,
  // not one a tick), within the preload.
  batch_ = std::clamp<std::size_t>(static_cast<std::size_t>(rate_hz / 1000.0), 1, preload_ / 2);
  // The level is judged over a tenth of a second: many of the card's bursts.
  drift_ = DriftKeeper(preload_, std::max<std::size_t>(1, std::size_t(rate_hz / 10) / batch_));
  history_scans_ = preload_ + batch_ + 2;
  if (!prepare_handle()) {
    throw std::runtime_error(fmt::format("comedi {}: {}", device_.path(),
                                         ComediDevice::last_error("comedi_set_write_subdevice")));
  }
}

OutputScan::~OutputScan() { stop_stream(); }

std::size_t OutputScan::join(unsigned channel, unsigned range, std::uint32_t raw) {
  stop_stream();
  pending_ = 0;
  channels_.push_back({next_id_, CR_PACK(channel, range, AREF_GROUND)});
  chanlist_.push_back(channels_.back().packed);
  scan_.push_back(raw);
  // Allocated here, once: the drive loop's calls never allocate.
  const std::size_t n = channels_.size();
  history_.assign(history_scans_ * n, 0);
  stored_ = 0;
  bytes_.assign((history_scans_ + batch_ + 2) * n * sample_bytes_, 0);
  // The card must clock the scan at the drive rate exactly: a rate it
  // rounds would stretch every period, and a card converts a scan's
  // channels in turn, so more channels may not fit a period.
  comedi_cmd cmd = stream_command(subdevice_, chanlist_, period_ns(rate_hz_));
  int tested = comedi_command_test(device_.get(), &cmd);
  if (tested == 4) tested = comedi_command_test(device_.get(), &cmd);  // arguments adjusted
  if (tested != 0 || cmd.scan_begin_arg != period_ns(rate_hz_)) {
    leave(next_id_);
    throw std::runtime_error(fmt::format(
        "comedi {}: subdevice {} cannot clock a scan of {} channel{} at drive.rate_hz = {:g} Hz "
        "(the driver offers {:g} Hz; command test stage {}); choose a rate the card divides "
        "exactly",
        device_.path(), subdevice_, n, n == 1 ? "" : "s", rate_hz_,
        cmd.scan_begin_arg > 0 ? 1e9 / cmd.scan_begin_arg : 0.0, tested));
  }
  return next_id_++;
}

void OutputScan::leave(std::size_t id) {
  stop_stream();
  pending_ = 0;
  const std::size_t i = index_of(id);
  if (i == channels_.size()) return;
  channels_.erase(channels_.begin() + static_cast<long>(i));
  chanlist_.erase(chanlist_.begin() + static_cast<long>(i));
  scan_.erase(scan_.begin() + static_cast<long>(i));
  history_.assign(history_scans_ * channels_.size(), 0);
  stored_ = 0;
}

std::size_t OutputScan::index_of(std::size_t id) const {
  std::size_t i = 0;
  while (i < channels_.size() && channels_[i].id != id) ++i;
  return i;
}

bool OutputScan::prepare_handle() {
  if (comedi_get_write_subdevice(device_.get()) != static_cast<int>(subdevice_) &&
      comedi_set_write_subdevice(device_.get(), subdevice_) < 0) {
    return false;
  }
  // Writes never block the drive loop: a full buffer is the card's clock
  // running behind, handled in flush().
  const int fd = comedi_fileno(device_.get());
  return fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK) == 0;
}

bool OutputScan::reopen() { return device_.reopen() && prepare_handle(); }

double OutputScan::latency_s() const {
  // A value waits for its batch, then behind the preload.
  return preload_latency_s(preload_ + batch_ - 1, rate_hz_);
}

long OutputScan::queued_now() const {
  if (device_.get() == nullptr || channels_.empty()) return -1;
  const int bytes = comedi_get_buffer_contents(device_.get(), subdevice_);
  return bytes < 0 ? -1 : bytes / static_cast<long>(sample_bytes_ * channels_.size());
}

Status OutputScan::write(std::size_t id, std::uint32_t raw) {
  const std::size_t i = index_of(id);
  scan_[i] = raw;
  channels_[i].written = channels_[i].active = true;
  for (const Channel& c : channels_) {
    if (!c.written) return Status::ok;
  }
  return commit();
}

Status OutputScan::end_tick() {
  for (const Channel& c : channels_) {
    if (c.written) return commit();
  }
  return last_;
}

Status OutputScan::commit() {
  for (Channel& c : channels_) c.written = false;
  if (!streaming_) {
    // The preload goes in before the start, so the card never waits on the loop.
    for (std::size_t slot = 0; slot < preload_; ++slot) store(slot);
    return last_ = start_stream(preload_);
  }
  store(pending_++);
  return last_ = pending_ < batch_ ? Status::ok : flush();
}

void OutputScan::store(std::size_t slot) {
  const std::size_t n = channels_.size();
  std::copy(scan_.begin(), scan_.end(), history_.begin() + static_cast<long>((stored_++ % history_scans_) * n));
  encode(slot, scan_.data());
}

void OutputScan::encode(std::size_t slot, const std::uint32_t* values) {
  const std::size_t n = channels_.size();
  for (std::size_t k = 0; k < n; ++k) {
    unsigned char* at = bytes_.data() + (slot * n + k) * sample_bytes_;
    if (sample_bytes_ == sizeof(lsampl_t)) {
      const lsampl_t v = values[k];
      std::memcpy(at, &v, sizeof v);
    } else {
      const auto v = static_cast<sampl_t>(values[k]);
      std::memcpy(at, &v, sizeof v);
    }
  }
}

bool OutputScan::send(std::size_t scans) {
  if (device_.get() == nullptr) return false;
  const std::size_t scan_bytes = channels_.size() * sample_bytes_;
  const ssize_t n = ::write(comedi_fileno(device_.get()), bytes_.data(), scans * scan_bytes);
  if (n < 0) return false;
  scans_queued_ += static_cast<std::uint64_t>(n) / scan_bytes;
  return true;
}

Status OutputScan::start_stream(std::size_t preloaded) {
  comedi_cmd cmd = stream_command(subdevice_, chanlist_, period_ns(rate_hz_));
  if ((device_.get() == nullptr && !reopen()) || comedi_command(device_.get(), &cmd) < 0) {
    return Status::io_error;
  }
  pending_ = 0;
  if (!send(preloaded) || comedi_internal_trigger(device_.get(), subdevice_, 0) < 0) {
    comedi_cancel(device_.get(), subdevice_);
    return Status::io_error;
  }
  streaming_ = true;
  drift_.reset();
  return Status::ok;
}

void OutputScan::stop_stream() {
  if (streaming_ && device_.get() != nullptr) comedi_cancel(device_.get(), subdevice_);
  streaming_ = false;
}

Status OutputScan::flush() {
  const long queued = queued_now();
  if (queued >= 0) {
    // The drift keeper's correction: the last scan twice, or left out.
    const std::size_t copies = drift_.copies(static_cast<std::size_t>(queued));
    if (copies == 2) store(pending_++);
    if (copies == 0) {
      --pending_;
      --stored_;
    }
    const std::size_t scans = pending_;
    pending_ = 0;
    if (send(scans)) return Status::ok;
  }
  // The card ran out of scans and stopped its stream (EPIPE): a missed
  // deadline. It restarts at the values due now, never replaying old ones.
  pending_ = 0;
  if (queued < 0 || errno == EPIPE) {
    ++underruns_;
    stop_stream();
    for (std::size_t slot = 0; slot < preload_; ++slot) store(slot);
    (void)start_stream(preload_);
    return Status::timeout;
  }
  return Status::io_error;
}

Status OutputScan::write_now(std::size_t id, std::uint32_t raw) {
  const std::size_t i = index_of(id);
  const bool was_streaming = streaming_;
  const long queued = was_streaming ? std::max(0L, queued_now()) : 0;
  const std::size_t unsent = pending_;
  stop_stream();
  pending_ = 0;
  scan_[i] = raw;
  channels_[i].written = channels_[i].active = false;
  // What is queued for the others goes again with this channel held at raw.
  const std::size_t n = channels_.size();
  for (std::size_t s = 0; s < history_scans_; ++s) history_[s * n + i] = raw;
  const unsigned packed = channels_[i].packed;
  const auto put = [&] {
    return device_.get() != nullptr &&
           comedi_data_write(device_.get(), subdevice_, CR_CHAN(packed), CR_RANGE(packed),
                             AREF_GROUND, raw) >= 0;
  };
  // A handle that no longer reaches the card (closed under the run, the card
  // re-enumerated) fails here: the stop's value goes through the card opened
  // again by its path. Its stream ended with the handle that started it.
  if (!put() && !(reopen() && put())) return Status::io_error;
  const bool others = std::any_of(channels_.begin(), channels_.end(),
                                  [](const Channel& c) { return c.active; });
  if (was_streaming && others) resend(static_cast<std::size_t>(queued) + unsent);
  return Status::ok;
}

void OutputScan::resend(std::size_t scans) {
  // The last `scans` stored (the ring holds a preload and a batch: what the
  // drift keeper lets queue), at least a preload: short of one, the oldest
  // is held a little longer, as a stream's start holds its first scan.
  const std::size_t n = channels_.size();
  const std::size_t kept = std::min({scans, history_scans_, stored_});
  const std::size_t total = std::max(kept, preload_);
  for (std::size_t slot = 0; slot < total; ++slot) {
    const std::size_t back = kept - std::min(kept, total - slot);  // 0..kept-1, front padded
    encode(slot, kept == 0 ? scan_.data()
                           : history_.data() + ((stored_ - kept + back) % history_scans_) * n);
  }
  last_ = start_stream(total);
}

}  // namespace piezo::hal::comedi
