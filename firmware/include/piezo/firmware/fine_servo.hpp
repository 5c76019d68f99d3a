#pragma once
/// @file
/// A move's fine servo: inside one step, the stator held at a DC set point
/// in [0, V_max]. In stick the rotor follows the stator (rad_per_V per
/// volt), so an integral law on the averaged angle's error closes in on the
/// target. The output slews slowly toward the set point (the rotor must
/// stick), or fast for a lift (the stator slips under the rotor, which
/// stays). Used by the fine stage and the active hold; allocation-free.

namespace piezo::firmware {

class FineServo {
 public:
  struct Settings {
    double rad_per_V = 31.4e-6;    ///< angle per volt in stick
    double V_max = 64.0;           ///< the set point's range is [0, V_max]
    double slow_V_per_s = 400.0;   ///< slow enough for the rotor to stick
    double fast_V_per_s = 8000.0;  ///< a lift: the stator slips under the rotor
  };
  static constexpr double kGain = 0.1;  ///< of the error corrected per reading

  explicit FineServo(const Settings& s) : s_(s) {}

  /// Toward `V` slowly (clamped to the range): the rotor follows.
  void raise_to(double V);
  /// Toward `V` fast (clamped to the range): the rotor stays; then slowly.
  void lift_to(double V);
  /// The output `dt` after `V`, slew-limited toward the set point. True in
  /// `lift_done` when a lift has just reached it (the rotor may have moved
  /// a little: the caller's readings should settle).
  [[nodiscard]] double output(double V, double dt, bool& lift_done);
  /// Whether a reading may correct the set point: not lifting, and the
  /// output (`V`) has caught up with it, so the integrator never winds up
  /// against the slew limit.
  [[nodiscard]] bool integrating(double V) const { return !lifting_ && V == set_; }
  /// One reading's correction for `aim_error` [rad]: a kGain share of it,
  /// within the range; with `side` +1 (or -1) only ever up (or down), as
  /// an approach from one side asks (0: either way).
  void correct(double aim_error, double side);
  /// The set point at an end of its range with the error still beyond
  /// `tolerance_rad` the same way: the servo cannot get there.
  [[nodiscard]] bool at_range_end(double aim_error, double tolerance_rad) const;
  [[nodiscard]] double set_point() const { return set_; }
  [[nodiscard]] bool lifting() const { return lifting_; }

 private:
  Settings s_;
  double set_ = 0.0;
  bool lifting_ = false;
};

}  // namespace piezo::firmware
