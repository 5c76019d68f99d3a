// parallel_for as the studies and identify use it: every job once, the
// progress ending on the whole, failures and interruptions brought back to
// the caller.
#include "jobs/parallel.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <stdexcept>
#include <thread>
#include <vector>

namespace piezo::host {
namespace {

TEST(ParallelFor, EachJobRunsOnceAndTheLastReportIsTheWhole) {
  constexpr std::size_t kJobs = 1000;
  std::vector<std::atomic<int>> runs(kJobs);
  std::vector<std::size_t> reported;
  parallel_for(
      kJobs, [&](std::size_t i) { ++runs[i]; },
      [&](std::size_t done, std::size_t total) {
        EXPECT_EQ(total, kJobs);
        reported.push_back(done);
      });
  for (std::size_t i = 0; i < kJobs; ++i) EXPECT_EQ(runs[i].load(), 1) << "job " << i;
  ASSERT_FALSE(reported.empty());
  EXPECT_EQ(reported.back(), kJobs);
  for (std::size_t k = 1; k < reported.size(); ++k) EXPECT_LT(reported[k - 1], reported[k]);
}

TEST(ParallelFor, AFailureIsRethrownOnceEveryJobHasRun) {
  std::atomic<int> ran{0};
  EXPECT_THROW(parallel_for(
                   50,
                   [&](std::size_t i) {
                     ++ran;
                     if (i == 3) throw std::runtime_error("job 3");
                   },
                   [](std::size_t, std::size_t) {}),
               std::runtime_error);
  EXPECT_EQ(ran.load(), 50);
}

std::atomic<bool> stop_asked{false};
std::atomic<bool> stop_seen{false};

void stop_when_asked() {
  if (stop_asked.load()) {
    stop_seen = true;
    throw std::runtime_error("interrupted");
  }
}

TEST(ParallelFor, AnInterruptionIsRethrownOnceTheJobsUnderWayHaveEnded) {
  // Job 0 asks to stop; every other job holds until the caller's thread has
  // seen the request, so the interruption always finds jobs under way.
  set_interruption_check(&stop_when_asked);
  std::atomic<std::size_t> begun{0}, ended{0};
  EXPECT_THROW(parallel_for(
                   1000,
                   [&](std::size_t i) {
                     ++begun;
                     if (i == 0) stop_asked = true;
                     while (!stop_seen.load()) std::this_thread::yield();
                     ++ended;
                   },
                   [](std::size_t, std::size_t) {}),
               std::runtime_error);
  set_interruption_check(nullptr);
  EXPECT_EQ(begun.load(), ended.load());
}

TEST(ParallelFor, AnInterruptionStopsTheJobsUnderWayAtTheirNextInterruptionPoint) {
  // Jobs that would never end by themselves (a stiff simulation's minutes)
  // stop at their next interruption_point once the caller's thread has
  // seen the interruption: parallel_for returns instead of waiting on them.
  stop_asked = false;
  stop_seen = false;
  set_interruption_check(&stop_when_asked);
  std::atomic<std::size_t> stopped{0};
  EXPECT_THROW(parallel_for(
                   4,
                   [&](std::size_t i) {
                     if (i == 0) stop_asked = true;
                     try {
                       for (;;) {
                         interruption_point();
                         std::this_thread::yield();
                       }
                     } catch (const JobsStopped&) {
                       ++stopped;
                       throw;
                     }
                   },
                   [](std::size_t, std::size_t) {}),
               std::runtime_error);  // the caller's interruption, not the workers' stop
  set_interruption_check(nullptr);
  EXPECT_GE(stopped.load(), 1U);
}

}  // namespace
}  // namespace piezo::host
