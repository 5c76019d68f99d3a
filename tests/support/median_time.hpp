#pragma once
// The benches' timer: the median wall time of `repeats` calls, so one
// disturbed call on a shared machine does not move the figure.

#include <algorithm>
#include <chrono>
#include <functional>
#include <vector>

namespace piezo::testing {

inline double median_seconds(int repeats, const std::function<void()>& run) {
  std::vector<double> times;
  for (int i = 0; i < repeats; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    run();
    times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(times.begin(), times.end());
  return times[times.size() / 2];
}

}  // namespace piezo::testing
