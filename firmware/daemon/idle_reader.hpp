#pragma once
// Between runs the board goes on reading every axis's sensor at its idle
// rate ([piezod] idle_rate_hz), the drive left at 0 V, so that a position
// is always known and a rotor that moves at rest is seen (docs/protocol.md,
// "At rest"). One thread of normal priority for every axis; its readings
// reach the network thread through a ring, as a run's do. Whatever else
// uses the sensors (a run, readings before a move) takes a Hold first: no
// idle reading runs while one is held. Internal to the daemon's sources.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <thread>
#include <vector>

#include "piezo/firmware/spsc_ring.hpp"
#include "piezo/hal/clock.hpp"
#include "piezo/hal/displacement_sensor.hpp"

namespace piezo::daemon {

/// Steady (wall) time [ns]: ages and the virtual clock's lease are on it.
inline std::int64_t steady_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

struct IdleReading {
  hal::TimeNs t_response = 0;  ///< the board's clock
  std::int64_t wall_ns = 0;    ///< steady time it was taken, for its age
  double displacement_m = 0.0;
  hal::Status status = hal::Status::ok;
  std::uint8_t axis = 0;  ///< the board's index
};

class IdleReader {
 public:
  /// Starts reading `sensors` at `rate_hz` (0: never; nothing is read
  /// between runs). `before_reading` is called before each turn's readings
  /// (the simulated rig carries its plants to now there), if given.
  IdleReader(hal::Clock& clock, std::vector<hal::DisplacementSensor*> sensors, double rate_hz,
             std::function<void()> before_reading = {});
  ~IdleReader();
  IdleReader(const IdleReader&) = delete;
  IdleReader& operator=(const IdleReader&) = delete;

  /// While one is held no idle reading runs; its constructor returns once
  /// the reading under way, if any, has ended.
  class Hold {
   public:
    explicit Hold(IdleReader& reader);
    Hold(Hold&& o) noexcept : reader_(o.reader_) { o.reader_ = nullptr; }
    Hold(const Hold&) = delete;
    Hold& operator=(const Hold&) = delete;
    Hold& operator=(Hold&&) = delete;
    ~Hold();

   private:
    IdleReader* reader_;
  };
  [[nodiscard]] Hold hold() { return Hold(*this); }

  /// The network thread's side: the next reading, if any.
  [[nodiscard]] bool next(IdleReading& out) { return ring_.try_pop(out); }
  /// Readings the ring could not take (the network thread behind).
  [[nodiscard]] std::uint64_t dropped() const { return dropped_.load(); }
  [[nodiscard]] double rate_hz() const { return rate_hz_; }

 private:
  void loop();
  /// One turn: every axis read once, unless a Hold is in.
  void read_all();

  hal::Clock& clock_;
  std::vector<hal::DisplacementSensor*> sensors_;
  std::function<void()> before_reading_;
  double rate_hz_;
  firmware::SpscRing<IdleReading> ring_;
  std::atomic<int> holds_{0};
  std::atomic<bool> reading_{false};
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> dropped_{0};
  std::thread thread_;  ///< last: it uses the members above
};

}  // namespace piezo::daemon
