#include "piezo/firmware/request_limits.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <variant>

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
  const double f_max = max_drive_frequency(b.rate_hz);
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
  for (const MoveField& field : kMoveFields) {
    const std::string name(field.name);
    const std::string unit = field.unit.empty() ? "" : " " + std::string(field.unit);
    Interval allowed = field.allowed;
    if (field.name == "timeout_s") allowed.max = std::min(allowed.max, timeout_max_s);
    std::optional<LimitBreach> breach;
    std::visit(
        [&](auto member) {
          using T = std::remove_cvref_t<decltype(m.*member)>;
          if constexpr (std::is_same_v<T, double>) {
            if (!allowed.admits(m.*member)) {
              breach = LimitBreach{name, fmt::format("{:g}{}; allowed: {}{}", m.*member, unit,
                                                     allowed.text(), unit)};
            }
          } else if constexpr (std::is_same_v<T, std::uint64_t>) {
            if (!allowed.admits(static_cast<double>(m.*member))) {
              breach =
                  LimitBreach{name, fmt::format("{}; allowed: {}", m.*member, allowed_text(field))};
            }
          }
        },
        field.member);
    if (breach) return breach;
  }
  if (!(m.hold_s < m.timeout_s)) {
    return LimitBreach{
        "hold_s", fmt::format("{:g} s; allowed: [0, timeout_s = {:g}) s", m.hold_s, m.timeout_s)};
  }
  return std::nullopt;
}

}  // namespace piezo::firmware
