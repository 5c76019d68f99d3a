#include "piezo/firmware/acquire_loop.hpp"

namespace piezo::firmware {

AcquireLoop::AcquireLoop(hal::Clock& clock, hal::DisplacementSensor& sensor, double rate_hz,
                         SensorHealth& sensor_health, SpscRing<SensorSample>& ring,
                         PositionFeed* feed)
    : clock_(clock),
      sensor_(sensor),
      period_(hal::from_seconds(1.0 / rate_hz)),
      sensor_health_(sensor_health),
      ring_(ring),
      feed_(feed) {}

void AcquireLoop::run(hal::TimeNs t0, const std::atomic<bool>& stop) {
  const hal::TimeNs period = period_;
  hal::TimeNs deadline = t0;
  while (!stop.load(std::memory_order_acquire)) {
    clock_.sleep_until(deadline);
    if (stop.load(std::memory_order_acquire)) break;
    health_.period_error.record(clock_.now() - deadline);
    health_.count(health_.cycles);

    const hal::DisplacementReading r = sensor_.read();
    const bool good = r.status == hal::Status::ok;
    sensor_health_.report(good, r.t_response);
    if (!good) health_.count(health_.errors);
    if (good && feed_ != nullptr) feed_->publish(r.displacement_m);
    if (!ring_.try_push({r.t_request, r.t_response, r.displacement_m, r.status})) {
      health_.count(health_.dropped_samples);
    }

    deadline += period;
    const hal::TimeNs done = clock_.now();
    if (done > deadline) {
      health_.count(health_.overruns);
      health_.count(health_.missed_cycles, skip_missed(deadline, done, period));
    }
  }
}

}  // namespace piezo::firmware
