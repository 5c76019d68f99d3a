#pragma once
/// @file
/// A drive that takes every write and drives nothing, after a set write
/// latency: for checks of the loop and the lines alone, and for a drive
/// whose writes block as long as a slow analog-output module's.

#include <limits>

#include "piezo/hal/clock.hpp"
#include "piezo/hal/drive.hpp"

namespace piezo::hal::sim {

class NullDrive final : public Drive {
 public:
  /// Each write blocks `write_latency_s` on `clock` (0: returns at once).
  explicit NullDrive(Clock& clock, double write_latency_s = 0.0)
      : clock_(clock), latency_(from_seconds(write_latency_s)) {}

  Status write(double volts) override;
  [[nodiscard]] double acknowledged_V() const override { return acknowledged_V_; }
  [[nodiscard]] DriveLimits limits() const override { return {0.0, 100.0}; }

 private:
  Clock& clock_;
  TimeNs latency_;
  double acknowledged_V_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace piezo::hal::sim
