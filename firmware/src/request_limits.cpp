#include "piezo/firmware/request_limits.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "piezo/firmware/move_controller.hpp"

namespace piezo::firmware {

std::optional<LimitBreach> check_drive(const model::DriveParameters& d, double duration_s,
                                       const DriveBounds& b) {
  const auto& lim = b.limits;
  if (!(d.V0 > 0.0 && d.V0 <= lim.V_max && lim.V_min <= 0.0)) {
    return LimitBreach{"V0", fmt::format("{:g} V is outside the drive's limits; allowed: (0, "
                                         "{:g}] V (V_max; and V_min = {:g} V must be <= 0: the "
                                         "sawtooth spans 0..V0)",
                                         d.V0, lim.V_max, lim.V_min)};
  }
  const double f_max = b.rate_hz / 20.0;
  if (!(d.f > 0.0 && d.f <= f_max)) {
    return LimitBreach{"f", fmt::format("{:g} Hz gives under 20 drive samples per period at the "
                                        "drive's {:g} Hz; allowed: (0, {:g}] Hz",
                                        d.f, b.rate_hz, f_max)};
  }
  if (!(d.C_dr > 0.0 && d.C_dr <= 1.0)) {
    return LimitBreach{"C_dr", fmt::format("{:g}; allowed: (0, 1]", d.C_dr)};
  }
  if (!(d.e_dr >= 0.0 && d.e_dr < 1.0)) {
    return LimitBreach{"e_dr", fmt::format("{:g}; allowed: [0, 1)", d.e_dr)};
  }
  const double D = d.D();
  if (!(D > 0.0 && D < 1.0)) {
    return LimitBreach{"e_dr", fmt::format("with C_dr = {:g} the rise fraction D = {:g} is not "
                                           "inside (0, 1)",
                                           d.C_dr, D)};
  }
  const double edge = std::min(D, 1.0 - D);
  const double fastest = d.V0 * d.f / edge;
  if (fastest > lim.slew_V_per_s) {
    return LimitBreach{
        "V0", fmt::format("the sawtooth's fastest edge, V0*f/min(D, 1-D) = {:.4g} V/s, exceeds "
                          "the slew limit slew_V_per_s = {:g} V/s; allowed: V0*f <= {:.4g} V/s",
                          fastest, lim.slew_V_per_s, lim.slew_V_per_s * edge)};
  }
  if (!(duration_s > 0.0 && duration_s <= b.duration_max_s)) {
    return LimitBreach{"duration_s",
                       fmt::format("{:g} s; allowed: (0, {:g}] s", duration_s, b.duration_max_s)};
  }
  return std::nullopt;
}

std::optional<LimitBreach> check_move(const MoveRequest& m, double timeout_max_s) {
  if (m.stall_steps < 1 ||
      m.stall_steps > static_cast<std::uint64_t>(MoveSettings::kMaxStallSteps)) {
    return LimitBreach{"stall_steps", fmt::format("{}; allowed: 1..{}", m.stall_steps,
                                                  MoveSettings::kMaxStallSteps)};
  }
  if (!(std::abs(m.target_rad) <= 10.0)) {
    return LimitBreach{"target_rad", fmt::format("{:g} rad; allowed: [-10, 10] rad", m.target_rad)};
  }
  if (!(m.tolerance_rad > 0.0 && m.tolerance_rad <= 0.1)) {
    return LimitBreach{"tolerance_rad",
                       fmt::format("{:g} rad; allowed: (0, 0.1] rad", m.tolerance_rad)};
  }
  if (!(m.settle_s >= 0.0 && m.settle_s <= 10.0)) {
    return LimitBreach{"settle_s", fmt::format("{:g} s; allowed: [0, 10] s", m.settle_s)};
  }
  if (!(m.timeout_s > 0.0 && m.timeout_s <= timeout_max_s)) {
    return LimitBreach{"timeout_s",
                       fmt::format("{:g} s; allowed: (0, {:g}] s", m.timeout_s, timeout_max_s)};
  }
  if (!(m.hold_s >= 0.0 && m.hold_s < m.timeout_s)) {
    return LimitBreach{
        "hold_s", fmt::format("{:g} s; allowed: [0, timeout_s = {:g}) s", m.hold_s, m.timeout_s)};
  }
  return std::nullopt;
}

}  // namespace piezo::firmware
