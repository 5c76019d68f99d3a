#pragma once
// Where long work says how far it is. The command line writes to its own
// stderr; the Python package installs a sink that writes to Python's
// sys.stderr, which a notebook shows under the running cell (the process's
// stderr would reach only the kernel's terminal).

#include <fmt/core.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <functional>
#include <string>
#include <utility>

namespace piezo::host {

/// Writes `text` (a `\r`-led update of the current line, or whole lines)
/// where the user sees it; may throw to stop the work (a Python
/// KeyboardInterrupt raised while writing).
using ProgressSink = void (*)(const std::string& text);

inline std::atomic<ProgressSink> progress_sink{nullptr};

inline void set_progress_sink(ProgressSink sink) {
  progress_sink = sink;
}

inline void show_progress(const std::string& text) {
  if (const ProgressSink sink = progress_sink.load()) {
    sink(text);
  } else {
    std::fputs(text.c_str(), stderr);
  }
}

/// parallel_for's progress for `what`: "\rwhat: 12/40 <unit> done", the
/// line ended when all are.
inline std::function<void(std::size_t, std::size_t)> counted_progress(std::string what,
                                                                      std::string unit) {
  return [what = std::move(what), unit = std::move(unit)](std::size_t done, std::size_t total) {
    show_progress(
        fmt::format("\r{}: {}/{} {} done{}", what, done, total, unit, done == total ? "\n" : ""));
  };
}

/// A long simulation's progress, at most once a second: "simulate: t 12.0
/// of 60 s (20 %)", on one line rewritten in place (`overwrite`, a
/// terminal or a notebook) or a line each (a file). A simulation that
/// would take more than a minute at the rate of its first seconds says so
/// once, naming `parameters` (stiff ones shrink the steps a thousandfold:
/// the user should know before waiting, and that Ctrl-C stops it).
class SimulationProgress {
 public:
  SimulationProgress(double duration, bool overwrite, std::string parameters = {})
      : duration_(duration), overwrite_(overwrite), parameters_(std::move(parameters)) {}

  void operator()(double t) {
    const auto now = std::chrono::steady_clock::now();
    if (now - last_shown_ < std::chrono::seconds(1)) return;
    last_shown_ = now;
    shown_ = true;
    const std::string line =
        fmt::format("simulate: t {:.3g} of {:g} s ({:.0f} %)", t, duration_, 100.0 * t / duration_);
    show_progress(overwrite_ ? "\r" + line + "\x1b[K" : line + "\n");
    warn_if_slow(t, now);
  }

  /// Ends the rewritten line once the simulation is done.
  void finish() const {
    if (overwrite_ && shown_) show_progress("\n");
  }

 private:
  static constexpr double kSlowAfterSeconds = 60.0;

  void warn_if_slow(double t, std::chrono::steady_clock::time_point now) {
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    if (warned_ || elapsed < 2.0) return;
    const double rate = t / elapsed;  // simulated seconds per second
    const double remaining = rate > 0.0 ? (duration_ - t) / rate : INFINITY;
    if (remaining < kSlowAfterSeconds) return;
    warned_ = true;
    show_progress(fmt::format(
        "{}simulate: slow: {:.3g} s of motor in {:.0f} s; the remaining {:.3g} s would take "
        "about {:.0f} min. The integrator's steps are that short because the equations are "
        "stiff{}{}; Ctrl-C stops it\n",
        overwrite_ ? "\n" : "", t, elapsed, duration_ - t, remaining / 60.0,
        parameters_.empty() ? "" : " with ", parameters_));
  }

  double duration_;
  bool overwrite_;
  std::string parameters_;
  bool shown_ = false, warned_ = false;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  std::chrono::steady_clock::time_point last_shown_ = start_;
};

}  // namespace piezo::host
