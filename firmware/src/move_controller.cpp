#include "piezo/firmware/move_controller.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "piezo/firmware/voltage_limiter.hpp"
#include "piezo/model/waveform.hpp"

namespace piezo::firmware {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
/// Below about half of V0 a stick-slip step shrinks faster than its
/// amplitude (the rotor hardly slips): shorter steps are the fine stage's.
constexpr double kMinStepFraction = kStepFractions.front();
/// Far from the target (this many full steps) the steps follow each other
/// without waiting for the sensor to settle.
constexpr double kChainSteps = 3.0;
/// A lift overshoots the angle it is meant to give back by this much, so the
/// slow descent that follows has room.
constexpr double kLiftMargin = 1.3;
constexpr double kLiftExtra_V = 2.0;

}  // namespace

const char* to_string(MoveState s) {
  // The table's names are literals, so their data is a C string.
  return kMoveStateNames.name(s).data();
}

MoveController::MoveController(const MoveSettings& settings, const PositionFeed& feed)
    : s_(settings),
      feed_(feed),
      seen_(feed.count()),
      flush_(kNoiseReadings),  // the first decision waits for the noise at rest
      servo_({settings.rad_per_V, settings.fine_V_max, settings.fine_slew_V_per_s,
              settings.fast_slew_V_per_s}),
      zero_(settings.zero_displacement_m),
      zero_m_(settings.zero_displacement_m),
      noise_m_(kNaN),
      position_(kNaN),
      on_target_at_(kNaN),
      f_(settings.f) {
  steps_model_.use(settings.step_forward_rad, settings.step_reverse_rad);
}

double MoveController::next_voltage(double t, double dt) {
  const std::uint64_t count = feed_.count();
  if (count != seen_) {
    seen_ = count;
    on_reading(t, feed_.displacement_m());
  }
  switch (state()) {
    case MoveState::coarse: {
      if (!in_step_) return V_ = 0.0;
      const double T = 1.0 / s_.f;
      const double tau = t - step_start_;
      if (tau >= T) {
        steps_.fetch_add(1, std::memory_order_relaxed);
        check_progress();
        if (state() != MoveState::coarse) return V_ = 0.0;
        const double error = s_.target_rad - theta_f_;
        const double chain_from =
            kChainSteps * steps_model_.predicted(direction_ > 0 ? 0 : 1, 1.0) +
            (direction_ > 0 ? s_.rad_per_V * s_.V0 : 0.0);  // a forward step's peak
        if (error * direction_ > chain_from) {
          // Far away: the next full step at once. The readings lag the
          // rotor by the same amount at both ends, so the step is measured.
          learn_from_step();
          start_step(t, error);
          return V_ = 0.0;
        }
        in_step_ = false;
        step_done_ = true;
        flush_ = kFlush;
        return V_ = 0.0;
      }
      // One period of the paper's sawtooth at this step's amplitude and rise.
      return V_ = model::Sawtooth(amplitude_, s_.f, rise_).voltage(tau);
    }
    case MoveState::holding:
      if (hold_.over(t)) {
        // The hold is over: release, and settle at 0 V as after any hold.
        held_ = true;
        released_from_fine_ = false;
        set_state(MoveState::release);
        return V_;
      }
      [[fallthrough]];
    case MoveState::fine: {
      bool lift_done = false;
      V_ = servo_.output(V_, dt, lift_done);
      if (lift_done) flush_ = kFlush;  // the lift may have moved the rotor a little
      return V_;
    }
    case MoveState::release:
      V_ = step_towards(V_, 0.0, s_.fast_slew_V_per_s, dt);
      if (V_ == 0.0) {
        set_state(MoveState::settle);
        flush_ = kFlush;
        within_since_ = -1.0;
        settle_.start(settle_readings());
      }
      return V_;
    case MoveState::none:
    case MoveState::settle:
    case MoveState::on_target:
    case MoveState::stalled:
    case MoveState::sensor_implausible:
      break;
  }
  return V_ = 0.0;
}

StopCause MoveController::fault() const {
  switch (state()) {
    case MoveState::stalled:
      return StopCause::stalled;
    case MoveState::sensor_implausible:
      return StopCause::sensor_implausible;
    default:
      return StopCause::none;
  }
}

void MoveController::on_reading(double t, double displacement_m) {
  if (noise_n_ < kNoiseReadings && steps_.load(std::memory_order_relaxed) == 0 && !in_step_) {
    // At rest before the first step: the readings' spread is the noise.
    noise_sum_ += displacement_m;
    noise_sum2_ += displacement_m * displacement_m;
    if (++noise_n_ == kNoiseReadings) {
      const double n = kNoiseReadings, mean = noise_sum_ / n;
      noise_m_.store(std::sqrt(std::max(0.0, noise_sum2_ / n - mean * mean) * n / (n - 1.0)));
      if (!zero_.known()) {
        // No zero yet: the mean of the readings at rest (one reading's
        // noise would offset every later move).
        zero_.set(mean);
        zero_m_.store(mean);
      }
    }
  }
  const double mean_m = window_.add(displacement_m);
  if (!zero_.known()) return;  // until the readings at rest give it
  theta_f_ = zero_.angle_rad(mean_m, s_.r2_m);
  position_.store(theta_f_, std::memory_order_relaxed);
  if (flush_ > 0) {
    --flush_;
    return;
  }
  if (in_step_) {
    // The raw readings' extremes: a mean of 8 would smooth away the swing
    // of steps shorter than 8 readings (40 Hz with a 200 Hz sensor).
    const double theta = zero_.angle_rad(displacement_m, s_.r2_m);
    step_low_ = std::min(step_low_, theta);
    step_high_ = std::max(step_high_, theta);
  }
  const double error = s_.target_rad - theta_f_;
  if (masked()) {
    // A neighbour's steps shake this rotor: no correction for them, and a
    // settle starts again (its mean would hold the shake).
    switch (state()) {
      case MoveState::settle:
        within_since_ = -1.0;
        settle_.start(settle_readings());
        return;
      case MoveState::holding:
        hold_.record(error);  // the hold's account says what the shake did
        return;
      case MoveState::fine:
        steady_ = 0;
        return;
      default:
        break;
    }
  }
  switch (state()) {
    case MoveState::coarse:
      if (in_step_) return;
      if (step_done_) {
        step_done_ = false;
        learn_from_step();
      }
      decide(t, error);
      return;
    case MoveState::fine: {
      if (!servo_.integrating(V_)) return;
      const double aim_error = error + aim_offset_;
      // With an approach side the servo only ever moves the rotor that way
      // (in stick the rotor follows the stator): an overshoot is released
      // and passed, never backed out of.
      const double side = approach_side();
      servo_.correct(aim_error, side);
      if (error * side < -s_.tolerance_rad) {
        released_from_fine_ = true;  // what the release adds is learnt all the same
        set_state(MoveState::release);
        return;
      }
      // Held once the 8-reading mean stays within half the tolerance; a
      // noise that alone would keep it out widens the window (the settle's
      // longer mean judges the result).
      const double noise = this->noise();
      const double filter_noise =
          noise > 0.0 ? 2.0 * noise / (std::sqrt(double{kFilter}) * s_.r2_m) : 0.0;
      const double window =
          0.5 * s_.tolerance_rad + std::max(0.0, filter_noise - 0.25 * s_.tolerance_rad);
      steady_ = std::abs(aim_error) <= window ? steady_ + 1 : 0;
      if (steady_ >= kSteady || servo_.at_range_end(aim_error, s_.tolerance_rad)) {
        released_from_fine_ = steady_ >= kSteady;
        set_state(MoveState::release);
      }
      return;
    }
    case MoveState::settle:
      settle(t, displacement_m);
      return;
    case MoveState::holding:
      // The servo on the error itself (no aim offset: nothing is released
      // until the hold is over), either way.
      if (!servo_.integrating(V_)) return;
      servo_.correct(error, 0.0);
      hold_.record(error);
      return;
    case MoveState::release:
    case MoveState::none:
    case MoveState::on_target:
    case MoveState::stalled:
    case MoveState::sensor_implausible:
      return;
  }
}

int MoveController::settle_readings() const {
  const double noise = this->noise();
  if (!(noise > 0.0)) return kFilter;
  const double n = std::pow(8.0 * noise / (s_.r2_m * s_.tolerance_rad), 2.0);
  return static_cast<int>(std::clamp(std::ceil(n), double{kFilter}, double{SettleMean::kMax}));
}

void MoveController::settle(double t, double displacement_m) {
  // A sliding mean of as many readings at 0 V as the noise asks for.
  if (!settle_.add(displacement_m)) return;
  const double theta = zero_.angle_rad(settle_.mean(), s_.r2_m);
  const double error = s_.target_rad - theta;
  const double noise = this->noise();
  const double interval =
      noise > 0.0 ? 2.0 * noise / (s_.r2_m * std::sqrt(static_cast<double>(settle_.readings())))
                  : 0.0;
  if (std::abs(error) + interval <= s_.tolerance_rad) {
    if (wrong_way_) {
      // Within the tolerance, but reached from the side the move must not
      // arrive from: the fine stage comes in again from the approach side.
      within_since_ = -1.0;
      released_from_fine_ = false;
      decide(t, error);
      return;
    }
    if (within_since_ < 0.0) within_since_ = t;
    if (t - within_since_ >= s_.settle_s) {
      if (s_.hold_s > 0.0 && !held_) {
        // From 0 V the stator is lifted fast to the middle of the fine
        // range (it slips under the rotor), so the servo can correct
        // either way.
        hold_.start(t, s_.hold_s);
        aim_offset_ = 0.0;
        servo_.lift_to(0.5 * s_.fine_V_max);
        set_state(MoveState::holding);
        return;
      }
      position_.store(theta, std::memory_order_relaxed);
      on_target_at_.store(t);
      set_state(MoveState::on_target);
    }
    return;
  }
  within_since_ = -1.0;
  // Not clear either way: a mean of twice the readings narrows it.
  if (std::abs(error) - interval <= s_.tolerance_rad && settle_.widen()) return;
  if (released_from_fine_) {
    // What the release moved the rotor by: the next hold aims off by it.
    const double limit = 0.25 * s_.fine_V_max * s_.rad_per_V;
    aim_offset_ = std::clamp(aim_offset_ + error, -limit, limit);
  }
  released_from_fine_ = false;
  decide(t, error);
}

double MoveController::noise() const {
  const double measured = noise_m_.load();
  if (std::isnan(s_.noise_prior_m)) return measured;
  return std::isnan(measured) ? s_.noise_prior_m : std::max(measured, s_.noise_prior_m);
}

ProgressFloors MoveController::floors() const {
  // A move's resolution is half its tolerance; the stroke is this step's.
  return {noise(), s_.r2_m, s_.rad_per_V * amplitude_, 0.5 * s_.tolerance_rad};
}

void MoveController::begin_run_of_steps() {
  judge_.begin(static_cast<int>(std::min<std::uint64_t>(s_.stall_steps, kMaxStallSteps)), theta_f_,
               window_.counts());
}

void MoveController::check_progress() {
  if (!s_.protect || !judge_.running()) return;
  const ProgressFloors floors = this->floors();
  const auto verdict =
      judge_.end_unit(theta_f_, window_.counts(), step_low_, step_high_, direction_, floors);
  // No step of a stick-slip motor goes far beyond the stator's stroke,
  // whatever the prediction (the model may predict almost none at V0).
  const auto& table = steps_model_.table(direction_ > 0 ? 0 : 1);
  const double largest =
      std::max(s_.implausible_step_factor * table.back(), 2.0 * s_.rad_per_V * s_.V0);
  if (std::abs(judge_.last_unit_rad()) > largest + ProgressJudge::progress_floor(floors) ||
      verdict == ProgressJudge::Verdict::implausible) {
    // Far more than any step of this motor; or frozen, blind, or moving
    // against the drive.
    set_state(MoveState::sensor_implausible);
  } else if (verdict == ProgressJudge::Verdict::stalled) {
    // Blocked, or a contact that does not slip at this frequency: another
    // may step; when none is left, stalled.
    if (try_alternative()) {
      begin_run_of_steps();
    } else {
      set_state(MoveState::stalled);
    }
  } else if (judge_.completed() >= static_cast<int>(s_.stall_steps) &&
             judge_.progress_rad() < 0.25 * static_cast<double>(s_.stall_steps) * predicted_ &&
             try_alternative()) {
    // Progress, but far less than predicted: another frequency may do
    // better (a stiffer contact steps at a higher one); judged afresh.
    begin_run_of_steps();
  }
}

bool MoveController::try_alternative() {
  if (next_alternative_ >= s_.alternative_count) return false;
  const MoveSettings::Alternative& a =
      s_.alternatives[static_cast<std::size_t>(next_alternative_++)];
  s_.f = a.f;
  steps_model_.use(a.forward_rad, a.reverse_rad);
  f_.store(a.f);
  return true;
}

double MoveController::approach_side() const {
  switch (s_.approach) {
    case Approach::forward:
      return 1.0;
    case Approach::reverse:
      return -1.0;
    case Approach::either:
      break;
  }
  return 0.0;
}

void MoveController::decide(double t, double error) {
  // A target on the side the move must not arrive from: a step aimed one
  // full step past it (a shorter one may not slip at all), so that what
  // follows comes back from the approach side, as precision stages do
  // against hysteresis and backlash.
  const double side = approach_side();
  if (error * side < 0.0) {
    start_step(t, error - side * steps_model_.predicted(side > 0.0 ? 1 : 0, 1.0));
    return;
  }
  // Forward, the fine stage raises the stator through most of its range;
  // backward it first lifts it (with a margin) and then lowers it.
  const double fine_window = (error > 0.0 ? 0.9 : 0.5) * s_.fine_V_max * s_.rad_per_V;
  if (std::abs(error) <= fine_window) {
    enter_fine(error);
  } else {
    start_step(t, error);
  }
}

void MoveController::learn_from_step() {
  // The step as measured against the step as predicted: the scale moves
  // most of the way (geometrically) toward what was seen. Steps lost in the
  // sensor's noise teach nothing.
  steps_model_.learn(direction_ > 0 ? 0 : 1, (theta_f_ - theta_before_) * direction_, predicted_,
                     4.0 * s_.tolerance_rad);
}

void MoveController::start_step(double t, double error) {
  const double direction = error > 0.0 ? 1.0 : -1.0;
  if (state() != MoveState::coarse || direction != direction_ || !judge_.running()) {
    begin_run_of_steps();  // a new run of steps: progress is judged from here
  }
  direction_ = direction;
  wrong_way_ = direction * approach_side() < 0.0;
  const int k = error > 0.0 ? 0 : 1;
  // The amplitude whose predicted step is the distance left (at most V0).
  double fraction = steps_model_.fraction_for(k, std::abs(error));
  if (error > 0.0) {
    // Forward, the rotor rides the slow rise (rad_per_V per volt) before
    // the fast fall slips the stator back under it: a step's peak stays
    // short of the target.
    fraction = std::clamp(error / (s_.rad_per_V * s_.V0), kMinStepFraction, fraction);
  }
  amplitude_ = fraction * s_.V0;
  predicted_ = steps_model_.predicted(k, fraction);
  rise_ = error > 0.0 ? s_.D : 1.0 - s_.D;
  step_start_ = t;
  theta_before_ = theta_f_;
  step_low_ = step_high_ = theta_f_;
  in_step_ = true;
  set_state(MoveState::coarse);
}

void MoveController::enter_fine(double error) {
  judge_.end_run();
  wrong_way_ = false;  // the fine stage moves the approach's way
  const double side = approach_side();
  // The approach side decides the fine stage's direction; the aim offset
  // only corrects how far it goes.
  const double aim_error =
      side != 0.0 && (error + aim_offset_) * side < 0.0 ? 0.0 : error + aim_offset_;
  steady_ = 0;
  if (side > 0.0 || (side == 0.0 && aim_error >= 0.0)) {
    // Forward: raise the stator slowly; the rotor sticks and follows. With
    // an approach side the servo cannot back out of an overshoot, so it
    // starts at half the way and closes in.
    servo_.raise_to((side > 0.0 ? 0.5 : 1.0) * aim_error / s_.rad_per_V);
  } else {
    // Backward: lift fast (the stator slips under the rotor), then lower slowly.
    servo_.lift_to(kLiftMargin * -aim_error / s_.rad_per_V + kLiftExtra_V);
  }
  set_state(MoveState::fine);
}

}  // namespace piezo::firmware
