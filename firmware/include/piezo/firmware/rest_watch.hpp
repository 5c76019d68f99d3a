#pragma once
/// @file
/// What an axis's readings at rest say (docs/protocol.md, "At rest"): where
/// it is, how noisy its sensor is, and whether the rotor moved while nothing
/// drove it (crept, was knocked, turned by hand). A rest begins at the
/// board's start and at the end of every run; its first readings are the
/// reference the rest is measured from. Fed by the board's network thread
/// with the idle reader's readings; fixed storage, no allocation.

#include <array>
#include <cstddef>
#include <optional>

namespace piezo::firmware {

/// The noise of a reading from successive differences, by their median: a
/// rotor still creeping or one odd reading does not pass for noise. NaN
/// for fewer than three readings.
double noise_of_readings(const double* readings, std::size_t n);

class RestWatch {
 public:
  /// Readings averaged for a position (and the reference).
  static constexpr std::size_t kMean = 8;
  /// Readings the noise is estimated from.
  static constexpr std::size_t kWindow = 32;
  /// A rotor moved at rest when its position (the mean of the latest kMean
  /// readings, all within this many noises of each other: the move is
  /// over) is this many noises of one reading from where it was last
  /// reported...
  static constexpr double kMovedNoises = 6.0;
  /// ... and at least this far [m]: a sensor quiet to its last bit (a
  /// simulated one without noise) does not report its quantisation.
  static constexpr double kMovedFloor_m = 0.1e-6;

  /// A move at rest, reported once it is over.
  struct Move {
    double moved_m;       ///< since the last report (or the rest's reference)
    double since_rest_m;  ///< since the rest's reference
  };

  /// A new rest: its reference is taken from the next kMean readings.
  void begin();
  /// A good reading at rest: a move, when it shows one that is over.
  std::optional<Move> add(double displacement_m);

  /// The mean of the latest kMean readings (nullopt: fewer yet).
  [[nodiscard]] std::optional<double> position_m() const;
  /// A reading's noise over the window (nullopt: fewer than 3 readings).
  [[nodiscard]] std::optional<double> noise_m() const;
  /// The rest's reference, once it has kMean readings.
  [[nodiscard]] std::optional<double> reference_m() const { return reference_m_; }
  /// From the reference to the position (0 before both are known).
  [[nodiscard]] double since_rest_m() const;
  /// Whether a move was reported in this rest.
  [[nodiscard]] bool moved() const { return moved_; }
  /// The threshold a move must pass: kMovedNoises noises, kMovedFloor_m at least.
  [[nodiscard]] double threshold_m() const;

 private:
  [[nodiscard]] double at(std::size_t back) const;  ///< 0: the latest
  [[nodiscard]] bool settled() const;

  std::array<double, kWindow> readings_{};
  std::size_t count_ = 0;  ///< readings in this rest, all told
  std::optional<double> reference_m_, reported_m_;
  bool moved_ = false;
};

}  // namespace piezo::firmware
