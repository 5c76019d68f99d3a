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

/// The median wall time of each of `runs`, called in turn `repeats` times
/// (run 0, run 1, ..., run 0, ...): a figure meant to be set beside another
/// (a speed-up, an overhead) then comes from the same spells of a shared
/// machine's load, which last seconds, as the figure it is set against.
inline std::vector<double> interleaved_median_seconds(
    int repeats, const std::vector<std::function<void()>>& runs) {
  std::vector<std::vector<double>> times(runs.size());
  for (int i = 0; i < repeats; ++i) {
    for (std::size_t r = 0; r < runs.size(); ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      runs[r]();
      times[r].push_back(
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
  }
  std::vector<double> medians;
  for (auto& t : times) {
    std::sort(t.begin(), t.end());
    medians.push_back(t[t.size() / 2]);
  }
  return medians;
}

}  // namespace piezo::testing
