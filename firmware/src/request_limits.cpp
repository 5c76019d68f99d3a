#include "piezo/firmware/request_limits.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <variant>

#include "piezo/firmware/request_arguments.hpp"
#include "piezo/firmware/wire_keys.hpp"

namespace piezo::firmware {

std::optional<LimitBreach> check_drive(const model::DriveParameters& d, double duration_s,
                                       const DriveBounds& b) {
  namespace arg = arguments;
  const auto& lim = b.limits;
  if (!(arg::V0.within(lim.V_max).admits(d.V0) && lim.V_min <= 0.0)) {
    return LimitBreach{std::string(wire_key::V0),
                       fmt::format("{:g} V is outside the drive's limits; allowed: {} V "
                                   "(V_max; and V_min = {:g} V must be <= 0: the "
                                   "sawtooth spans 0..V0)",
                                   d.V0, arg::V0.within(lim.V_max).text(), lim.V_min)};
  }
  const Interval f_allowed = arg::f.within(max_drive_frequency(b.rate_hz));
  if (!f_allowed.admits(d.f)) {
    return LimitBreach{std::string(wire_key::f),
                       fmt::format("{:g} Hz gives under 20 drive samples per period at the "
                                   "drive's {:g} Hz; allowed: {} Hz",
                                   d.f, b.rate_hz, f_allowed.text())};
  }
  if (!arg::C_dr.allowed.admits(d.C_dr)) {
    return LimitBreach{std::string(wire_key::C_dr),
                       fmt::format("{:g}; allowed: {}", d.C_dr, allowed_text(arg::C_dr))};
  }
  if (!arg::e_dr.allowed.admits(d.e_dr)) {
    return LimitBreach{std::string(wire_key::e_dr),
                       fmt::format("{:g}; allowed: {}", d.e_dr, allowed_text(arg::e_dr))};
  }
  const double D = d.D();
  if (!(D > 0.0 && D < 1.0)) {
    return LimitBreach{std::string(wire_key::e_dr),
                       fmt::format("with C_dr = {:g} the rise fraction D = {:g} is not "
                                   "inside (0, 1)",
                                   d.C_dr, D)};
  }
  const double edge = std::min(D, 1.0 - D);
  const double fastest = d.V0 * d.f / edge;
  if (fastest > lim.slew_V_per_s) {
    return LimitBreach{
        std::string(wire_key::V0),
        fmt::format("the sawtooth's fastest edge, V0*f/min(D, 1-D) = {:.4g} V/s, exceeds "
                    "the slew limit slew_V_per_s = {:g} V/s; allowed: V0*f <= {:.4g} V/s",
                    fastest, lim.slew_V_per_s, lim.slew_V_per_s * edge)};
  }
  if (const Interval allowed = arg::duration_s.within(b.duration_max_s);
      !allowed.admits(duration_s)) {
    return LimitBreach{std::string(wire_key::duration_s),
                       fmt::format("{:g} s; allowed: {} s", duration_s, allowed.text())};
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
        std::string(wire_key::hold_s),
        fmt::format("{:g} s; allowed: [0, timeout_s = {:g}) s", m.hold_s, m.timeout_s)};
  }
  return std::nullopt;
}

}  // namespace piezo::firmware
