#include "piezo/firmware/acquire_loop.hpp"

#include <utility>

namespace piezo::firmware {

AcquireLoop::AcquireLoop(hal::Clock& clock, std::vector<AcquireAxis> axes, double rate_hz,
                         LoopHealth& health)
    : clock_(clock),
      axes_(std::move(axes)),
      period_(hal::from_seconds(1.0 / rate_hz)),
      health_(health) {}

void AcquireLoop::read(const AcquireAxis& axis) {
  const hal::DisplacementReading r = axis.sensor->read();
  const bool good = r.status == hal::Status::ok;
  axis.health->report(good, r.t_response);
  if (!good) health_.count(health_.errors);
  if (good && axis.feed != nullptr) axis.feed->publish(r.displacement_m, r.t_response);
  if (!axis.ring->try_push({r.t_request, r.t_response, r.displacement_m, r.status, axis.index})) {
    health_.count(health_.dropped_samples);
  }
}

void AcquireLoop::run(hal::TimeNs t0, const std::atomic<bool>& stop) {
  const hal::TimeNs period = period_;
  hal::TimeNs deadline = t0;
  while (!stop.load(std::memory_order_acquire)) {
    clock_.sleep_until(deadline);
    if (stop.load(std::memory_order_acquire)) break;
    health_.period_error.record(clock_.now() - deadline);
    health_.count(health_.cycles);
    for (const AcquireAxis& axis : axes_) read(axis);

    deadline += period;
    const hal::TimeNs done = clock_.now();
    if (done > deadline) {
      health_.count(health_.overruns);
      health_.count(health_.missed_cycles, skip_missed(deadline, done, period));
    }
  }
}

}  // namespace piezo::firmware
