#include "piezo/hal/sim/virtual_clock.hpp"

#include <gtest/gtest.h>

#include <string>
#include <thread>
#include <vector>

namespace piezo::hal::sim {
namespace {

TEST(VirtualClock, ALoneSleeperJumpsStraightToItsDeadline) {
  VirtualClock clock(100);
  SleeperScope scope(clock);
  clock.sleep_until(5'000'000'000);
  EXPECT_EQ(clock.now(), 5'000'000'000);
  clock.sleep_until(10);  // a past deadline returns at once, time never runs back
  EXPECT_EQ(clock.now(), 5'000'000'000);
}

// Two loops at 3 and 5 time units: the interleaving is the same every time,
// ties go to whoever asked first (b asked for 15 at 10, a at 12), and each wakes exactly at its
// deadline.
TEST(VirtualClock, ThreadsTakeTurnsInDeadlineOrder) {
  for (int repeat = 0; repeat < 20; ++repeat) {
    VirtualClock clock;
    std::string trace;  // only one announced thread runs at a time: no race
    auto loop = [&](char name, TimeNs period, SleeperScope scope) {
      const SleeperScope mine(std::move(scope));
      for (TimeNs t = period; t <= 15; t += period) {
        clock.sleep_until(t);
        EXPECT_EQ(clock.now(), t);
        trace += name;
        trace += std::to_string(t);
        trace += ' ';
      }
    };
    SleeperScope a_scope(clock), b_scope(clock);
    std::thread a(loop, 'a', 3, std::move(a_scope));
    std::thread b(loop, 'b', 5, std::move(b_scope));
    a.join();
    b.join();
    EXPECT_EQ(trace, "a3 b5 a6 a9 b10 a12 b15 a15 ") << "repeat " << repeat;
  }
}

}  // namespace
}  // namespace piezo::hal::sim
