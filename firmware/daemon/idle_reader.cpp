#include "idle_reader.hpp"

#include <chrono>
#include <cmath>
#include <utility>

namespace piezo::daemon {
namespace {

using Steady = std::chrono::steady_clock;

// The thread sleeps in slices of at most this: a daemon that stops waits
// no longer for it.
constexpr auto kSlice = std::chrono::milliseconds(20);

}  // namespace

IdleReader::IdleReader(hal::Clock& clock, std::vector<hal::DisplacementSensor*> sensors,
                       double rate_hz, std::function<void()> before_reading)
    : clock_(clock),
      sensors_(std::move(sensors)),
      before_reading_(std::move(before_reading)),
      rate_hz_(rate_hz),
      ring_(1024) {
  if (rate_hz_ > 0.0) thread_ = std::thread([this] { loop(); });
}

IdleReader::~IdleReader() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

IdleReader::Hold::Hold(IdleReader& reader) : reader_(&reader) {
  // Dekker's handshake with read_all (both sequentially consistent): the
  // thread either sees this hold before it reads, or this sees it reading
  // and waits for the reading to end.
  reader_->holds_.fetch_add(1);
  while (reader_->reading_.load()) std::this_thread::sleep_for(std::chrono::microseconds(200));
}

IdleReader::Hold::~Hold() {
  if (reader_ != nullptr) reader_->holds_.fetch_sub(1);
}

void IdleReader::loop() {
  const auto period =
      std::chrono::duration_cast<Steady::duration>(std::chrono::duration<double>(1.0 / rate_hz_));
  auto deadline = Steady::now();
  while (!stop_.load()) {
    read_all();
    deadline += period;
    // A late turn (a slow sensor) does not bunch the next ones up.
    if (deadline < Steady::now()) deadline = Steady::now();
    while (!stop_.load() && Steady::now() < deadline) {
      std::this_thread::sleep_for(std::min<Steady::duration>(kSlice, deadline - Steady::now()));
    }
  }
}

void IdleReader::read_all() {
  reading_.store(true);
  if (holds_.load() == 0) {
    // The virtual clock schedules the threads it knows of: this one, alone
    // while no run holds the sensors.
    const hal::SleeperScope sleeper(clock_);
    // Nothing is written to the drives: the run left them at 0 V with the
    // amplifier off, and a clocked output takes writes only in a run.
    if (before_reading_) before_reading_();
    for (std::size_t i = 0; i < sensors_.size() && holds_.load() == 0; ++i) {
      const hal::DisplacementReading r = sensors_[i]->read();
      const IdleReading reading{r.t_response, steady_ns(), r.displacement_m, r.status,
                                static_cast<std::uint8_t>(i)};
      if (!ring_.try_push(reading)) dropped_.fetch_add(1);
    }
  }
  reading_.store(false);
}

}  // namespace piezo::daemon
