#include "piezo/firmware/spsc_ring.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <thread>

namespace piezo::firmware {
namespace {

TEST(SpscRing, CapacityRoundsUpToAPowerOfTwo) {
  EXPECT_EQ(SpscRing<int>(1000).capacity(), 1024u);
  EXPECT_EQ(SpscRing<int>(1024).capacity(), 1024u);
}

TEST(SpscRing, RefusesWhenFullAndKeepsOrderAcrossWrapAround) {
  SpscRing<int> ring(4);
  int next_in = 0, next_out = 0;
  for (int round = 0; round < 5; ++round) {
    while (ring.try_push(next_in)) ++next_in;
    EXPECT_EQ(next_in - next_out, 4) << "a full ring holds exactly its capacity";
    int value = -1;
    ASSERT_TRUE(ring.try_pop(value));
    EXPECT_EQ(value, next_out++);
    ASSERT_TRUE(ring.try_pop(value));
    EXPECT_EQ(value, next_out++);
  }
  EXPECT_EQ(ring.drain([&](int v) { EXPECT_EQ(v, next_out++); }), 2u);
  int value;
  EXPECT_FALSE(ring.try_pop(value));
}

// Producer and consumer on two threads: every value arrives once, in order
// (the thread-sanitizer build checks the memory ordering).
TEST(SpscRing, TwoThreadsLoseNothingThatWasAccepted) {
  SpscRing<std::uint64_t> ring(256);
  constexpr std::uint64_t kCount = 200'000;
  std::uint64_t refused = 0;
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < kCount; ++i) {
      while (!ring.try_push(i)) ++refused;
    }
  });
  std::uint64_t expected = 0;
  while (expected < kCount) {
    std::uint64_t v;
    if (ring.try_pop(v)) {
      ASSERT_EQ(v, expected);
      ++expected;
    }
  }
  producer.join();
  EXPECT_EQ(expected, kCount);
}

}  // namespace
}  // namespace piezo::firmware
