// Bench: the drive loop's period error at 10 kHz on CLOCK_MONOTONIC beside
// cyclictest (rt-tests) at the same period and priority on this machine,
// and SPSC ring throughput. The loops run as in piezod, through
// firmware::LoopRunner, with a null sensor per axis at 1 kHz beside the drive; one to four
// simulated axes on one tick show what each added axis costs. Usage: bench_loops [seconds
// per measurement]. Figures, not assertions: the machines are shared and noisy.

#include <fmt/format.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "piezo/firmware/loop_runner.hpp"
#include "piezo/hal/posix/monotonic_clock.hpp"
#include "piezo/hal/sim/null_drive.hpp"
#include "piezo/hal/sim/null_sensor.hpp"
#include "piezo/hal/sim/plant.hpp"
#include "piezo/hal/sim/sim_drive.hpp"
#include "piezo/hal/sim/sim_lines.hpp"

namespace {

using namespace piezo;
constexpr int kPriority = 80;
constexpr double kRateHz = 10'000;

struct Row {
  std::string name;
  double p50_us, p99_us, max_us;
  std::uint64_t cycles;
  std::string note;
};

/// The drive loop driving `axes` axes, each on its own drive (a null one,
/// or a simulated plant's DAC), with a null sensor per axis at 1 kHz beside it.
Row measure_drive_loop(const std::string& name, int axes, bool plants, double seconds) {
  hal::posix::MonotonicClock clock;
  std::vector<std::unique_ptr<hal::sim::Plant>> plant;
  std::vector<std::unique_ptr<hal::Drive>> drive;
  std::vector<std::unique_ptr<hal::sim::NullSensor>> sensor;
  const model::Sawtooth saw(80.0, 10.0, 0.95 * 0.789);
  std::vector<std::unique_ptr<firmware::WaveformProgram>> program;
  std::vector<hal::sim::Plant*> enabled;
  for (int i = 0; i < axes; ++i) {
    plant.push_back(std::make_unique<hal::sim::Plant>(model::MotorParameters{},
                                                      hal::sim::AmplifierSettings{}, clock.now()));
    enabled.push_back(plant.back().get());
    if (plants) {
      drive.push_back(
          std::make_unique<hal::sim::SimDrive>(hal::sim::DacSettings{}, *plant.back(), clock));
    } else {
      drive.push_back(std::make_unique<hal::sim::NullDrive>(clock));
    }
    sensor.push_back(std::make_unique<hal::sim::NullSensor>(clock));
    program.push_back(std::make_unique<firmware::WaveformProgram>(saw));
  }
  hal::sim::SimLines lines({}, enabled, clock, clock.now());
  firmware::LoopRunnerSettings settings;
  settings.drive = {kRateHz, seconds};
  settings.priority = kPriority;
  std::vector<firmware::RunAxis> run_axes;
  for (int i = 0; i < axes; ++i) {
    run_axes.push_back({*drive[i], *sensor[i], *program[i], {0.0, 80.0, 20'000.0}, 0.1, {}});
  }
  firmware::LoopRunner runner(settings, std::move(run_axes), clock, lines);
  (void)runner.start({});
  const auto ignore_drive = [](const firmware::DriveSample&) {};
  const auto ignore_sensor = [](const firmware::SensorSample&) {};
  while (!runner.finished()) {  // a consumer, as in a run
    for (int i = 0; i < axes; ++i) runner.drain(i, ignore_drive, ignore_sensor);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  runner.join();
  const auto notes = runner.realtime_notes();
  for (const auto& note : notes) fmt::print("  {}: {}\n", name, note);
  const auto& h = runner.drive_health().period_error;
  return {name,       h.quantile_us(0.5), h.quantile_us(0.99),
          h.max_us(), h.count(),          "as in piezod (LoopRunner)"};
}

/// cyclictest at the same period and priority; quantiles from its histogram.
Row measure_cyclictest(double seconds) {
  const auto loops = static_cast<long>(seconds * kRateHz);
  const std::string cmd = fmt::format(
      "cyclictest --mlockall --priority={} --interval=100 --loops={} --threads=1 --quiet "
      "--histogram=2000 2>&1",
      kPriority, loops);
  FILE* pipe = popen(cmd.c_str(), "r");
  if (pipe == nullptr) return {"cyclictest", 0, 0, 0, 0, "could not start"};
  std::vector<std::uint64_t> bins(2000, 0);
  double max_us = 0;
  std::array<char, 512> line{};
  std::string text;
  while (fgets(line.data(), line.size(), pipe) != nullptr) {
    const std::string l(line.data());
    text += l;
    unsigned long bin = 0, count = 0;
    if (l[0] != '#' && std::sscanf(l.c_str(), "%lu %lu", &bin, &count) == 2 && bin < bins.size()) {
      bins[bin] = count;
    }
    double m = 0;
    if (std::sscanf(l.c_str(), "# Max Latencies: %lf", &m) == 1) max_us = m;
  }
  if (pclose(pipe) != 0) return {"cyclictest", 0, 0, 0, 0, "failed: " + text.substr(0, 200)};
  std::uint64_t total = 0;
  for (auto c : bins) total += c;
  auto quantile = [&](double q) {
    const auto rank = static_cast<std::uint64_t>(q * static_cast<double>(total - 1));
    std::uint64_t seen = 0;
    for (std::size_t i = 0; i < bins.size(); ++i) {
      seen += bins[i];
      if (seen > rank) return static_cast<double>(i + 1);
    }
    return max_us;
  };
  if (total == 0) return {"cyclictest", 0, 0, 0, 0, "no histogram"};
  return {"cyclictest (rt-tests)",
          quantile(0.5),
          quantile(0.99),
          max_us,
          total,
          fmt::format("SCHED_FIFO {}, mlockall", kPriority)};
}

double ring_throughput(std::uint64_t count) {
  firmware::SpscRing<firmware::DriveSample> ring(1 << 14);
  const auto start = std::chrono::steady_clock::now();
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < count; ++i) {
      const firmware::DriveSample s{static_cast<hal::TimeNs>(i), 1.0, {}, {}};
      while (!ring.try_push(s)) {
      }
    }
  });
  std::uint64_t received = 0;
  firmware::DriveSample s{};
  while (received < count) received += ring.try_pop(s) ? 1 : 0;
  producer.join();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return static_cast<double>(count) / seconds;
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::stod(argv[1]) : 10.0;
  fmt::print("period error at {:.0f} Hz, {} s each (wake-up lateness, 1 us bins)\n", kRateHz,
             seconds);

  std::vector<Row> rows;
  rows.push_back(measure_drive_loop("drive loop, null drive", 1, false, seconds));
  for (int axes = 1; axes <= 4; ++axes) {
    rows.push_back(measure_drive_loop(
        fmt::format("drive loop, {} simulated {}", axes, axes > 1 ? "axes" : "axis"), axes, true,
        seconds));
  }
  rows.push_back(measure_cyclictest(seconds));

  fmt::print("{:<34} {:>9} {:>9} {:>10} {:>9}  {}\n", "", "p50 [us]", "p99 [us]", "max [us]",
             "cycles", "scheduling");
  for (const auto& r : rows) {
    fmt::print("{:<34} {:>9.0f} {:>9.0f} {:>10.1f} {:>9}  {}\n", r.name, r.p50_us, r.p99_us,
               r.max_us, r.cycles, r.note);
  }
  const double rate = ring_throughput(20'000'000);
  fmt::print("SPSC ring, DriveSample ({} B), two threads: {:.1f} M samples/s\n",
             sizeof(firmware::DriveSample), rate / 1e6);
  return 0;
}
