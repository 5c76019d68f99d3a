#pragma once
/// @file
/// The motor's parameter set (paper Table 1) with the paper's own symbols,
/// and validation that names each violated parameter with its allowed range.

#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "piezo/name_table.hpp"

namespace piezo::model {

/// Which way the sawtooth turns the rotor: forward is the paper's slow rise
/// and fast fall; reverse mirrors it in time (fast rise, slow fall: the rise
/// fraction D becomes 1 - D), so the rotor slips the other way.
enum class Direction { forward, reverse };

inline constexpr auto kDirectionNames =
    names<Direction>({{Direction::forward, "forward"}, {Direction::reverse, "reverse"}});

[[nodiscard]] inline std::string_view name(Direction d) {
  return kDirectionNames.name(d);
}
[[nodiscard]] inline std::optional<Direction> parse_direction(std::string_view text) {
  return kDirectionNames.parse(text);
}

/// The rise fraction that drives the rotor in `direction` with a drive of rise fraction D.
[[nodiscard]] inline double rise_fraction(double D, Direction direction) {
  return direction == Direction::forward ? D : 1.0 - D;
}

/// Drive waveform parameters (docs/model.md section 1).
struct DriveParameters {
  double V0 = 80.0;     ///< peak amplifier output voltage [V]
  double f = 10.0;      ///< drive frequency [Hz]
  double C_dr = 0.95;   ///< commanded duty ratio [-]
  double e_dr = 0.789;  ///< identified signal-chain factor [-]

  Direction direction = Direction::forward;

  /// Effective rise fraction of each period of the forward drive.
  [[nodiscard]] double D() const { return C_dr * e_dr; }
  /// Rise fraction of the waveform driven, in its direction: D or 1 - D.
  [[nodiscard]] double rise() const { return rise_fraction(D(), direction); }
};

/// Mechanical and friction parameters (docs/model.md sections 2 and 3), SI units.
struct MotorParameters {
  double d_e = 0.55e-6;  ///< effective piezo coefficient [m/V] (10 Hz value)
  double M = 21.7e-3;    ///< stator mass [kg]
  double J = 4.48e-6;    ///< rotor inertia [kg m^2]
  double C = 20.0;       ///< stator damping [N s/m]
  double K = 28e6;       ///< stator stiffness [N/m]
  double r = 17.5e-3;    ///< contact radius [m]
  double mu = 0.1;       ///< friction coefficient [-]
  double F_N = 4.93e-3;  ///< normal force [N]
  double sigma0 = 1650;  ///< bristle stiffness [N/m]
  double sigma1 = 40;    ///< bristle damping [N s/m]
  double sigma2 = 1e-4;  ///< viscous friction [N s/m]

  /// Coulomb friction level F_c = mu * F_N.
  [[nodiscard]] double F_c() const { return mu * F_N; }
};

/// Everything the paper's model needs: drive plus motor.
struct Parameters {
  DriveParameters drive;
  MotorParameters motor;
};

/// Where a parameter lives and which values it may take.
struct ParameterSpec {
  std::string_view name;     ///< the paper's symbol, as used by --set and config keys
  std::string_view section;  ///< config section: "drive" or "model"
  std::string_view unit;
  double min;
  double max;
  bool min_inclusive;
  bool max_inclusive;
  double& (*ref)(Parameters&);

  /// Human-readable allowed range, e.g. "(0, inf)" or "[0, 1000]".
  [[nodiscard]] std::string range_text() const;
  [[nodiscard]] bool admits(double value) const;
};

/// All settable parameters, in Table 1 order.
[[nodiscard]] std::span<const ParameterSpec> parameter_specs();

/// The spec for a symbol, or nullptr when the name is not a parameter.
[[nodiscard]] const ParameterSpec* find_parameter(std::string_view name);

/// The parameters whose values differ from the paper's (Parameters{}), as
/// "J=1e-12 kg m^2, F_N=0.01 N"; empty when none does.
[[nodiscard]] std::string differences_from_paper(const Parameters& p);

/// One violated constraint: which parameter, and what is allowed.
struct ParameterIssue {
  std::string name;
  std::string message;
};

/// Checks every value (finite, within range) and the derived constraint
/// 0 < C_dr*e_dr < 1. Returns one issue per violation; empty means valid.
[[nodiscard]] std::vector<ParameterIssue> validate(const Parameters& p);

/// Reads a parameter by symbol; nullopt when unknown.
[[nodiscard]] std::optional<double> get_parameter(const Parameters& p, std::string_view name);

}  // namespace piezo::model
