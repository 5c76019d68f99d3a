#pragma once
/// @file
/// Drive voltages as functions of time, with their breakpoints, so that an
/// integrator can step exactly onto every kink of the input.

#include "piezo/model/parameters.hpp"

namespace piezo::model {

/// The voltage on one interval between breakpoints: V(t) = V_at_t0 + slope * (t - t0).
struct LinearPiece {
  double t0;
  double V_at_t0;
  double slope;  ///< [V/s]
  [[nodiscard]] double at(double t) const { return V_at_t0 + slope * (t - t0); }
};

/// The piece in force at a time, and the breakpoint where it ends.
struct PieceSpan {
  LinearPiece piece;
  double end;
};

/// A piecewise-linear voltage at the amplifier output as a function of time.
class Excitation {
 public:
  virtual ~Excitation() = default;
  /// Amplifier output voltage at time t [V]. Must be cheap and allocation-free.
  [[nodiscard]] virtual double voltage(double t) const = 0;
  /// The first time strictly after t where the voltage has a kink or jump.
  [[nodiscard]] virtual double next_breakpoint(double t) const = 0;
  /// The linear piece in force from t up to next_breakpoint(t).
  [[nodiscard]] virtual LinearPiece piece(double t) const = 0;
  /// Both at once: a drive that searches its pieces (a replayed log)
  /// searches once.
  [[nodiscard]] virtual PieceSpan span(double t) const { return {piece(t), next_breakpoint(t)}; }
};

/// The paper's sawtooth (docs/model.md section 1): a slow rise over D*T, a fast
/// fall back to zero over the rest of each period.
class Sawtooth final : public Excitation {
 public:
  /// @param V0 peak voltage [V], @param f frequency [Hz], @param D rise fraction in (0, 1).
  Sawtooth(double V0, double f, double D);

  [[nodiscard]] double voltage(double t) const override;
  [[nodiscard]] double next_breakpoint(double t) const override;
  [[nodiscard]] LinearPiece piece(double t) const override;

  [[nodiscard]] double period() const { return T_; }

 private:
  double V0_;
  double T_;
  double D_;
};

}  // namespace piezo::model
