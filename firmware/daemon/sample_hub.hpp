#pragma once
// Where a run's samples go on the board, apart from the commands: the
// recorder (memory ring, spill file), the stream's publishing, and `fetch`
// with each watcher's budget. Used by the daemon's network thread only.

#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <zmq.hpp>

#include "fetch_budget.hpp"
#include "piezo/firmware/loop_runner.hpp"
#include "piezo/firmware/request_arguments.hpp"
#include "piezo/firmware/samples.hpp"
#include "recorder.hpp"
#include "spill_file.hpp"

namespace piezo::daemon {

class SampleHub {
 public:
  /// Samples per fetch reply, at most (as `fetch`'s `count` declares).
  static constexpr std::uint64_t kMaxFetch = firmware::arguments::kMaxFetch;

  /// Recorders for `recorder_s` at the two rates; a spill file when
  /// `spill_file` is set; publishing on `stream`.
  SampleHub(double recorder_s, double drive_rate_hz, double sensor_rate_hz,
            const std::string& spill_file, double fetch_samples_per_s, zmq::socket_t& stream);

  /// A new run: numbering restarts at 0 and the spill file starts again.
  void clear();
  /// Takes what the loops produced, every axis's, into the recorder and
  /// publishes it (and spills it); `on_drive` sees each drive sample,
  /// `on_good_reading` each good reading (its axis, its displacement [m]).
  void take(firmware::LoopRunner& runner,
            const std::function<void(const firmware::DriveSample&)>& on_drive,
            const std::function<void(std::uint8_t, double)>& on_good_reading);
  /// `fetch` (docs/protocol.md): the samples as a frame; `budgeted` for a
  /// client that watches another's run. Throws ProtocolError.
  [[nodiscard]] nlohmann::json fetch(const std::string& client, const nlohmann::json& args,
                                     bool budgeted);

  [[nodiscard]] std::uint64_t drive_first() const { return drive_.first(); }
  [[nodiscard]] std::uint64_t sensor_first() const { return sensor_.first(); }
  [[nodiscard]] std::uint64_t drive_recorded() const { return drive_.next(); }
  [[nodiscard]] std::uint64_t sensor_recorded() const { return sensor_.next(); }
  [[nodiscard]] std::size_t drive_capacity() const { return drive_.capacity(); }

 private:
  template <class Sample>
  void publish(std::string_view topic, const Recorder<Sample>& recorder, std::uint64_t& published);

  Recorder<firmware::DriveSample> drive_;
  Recorder<firmware::SensorSample> sensor_;
  std::optional<SpillFile> spill_;
  FetchBudget budget_;
  zmq::socket_t& stream_;
  std::uint64_t drive_published_ = 0, sensor_published_ = 0;
};

}  // namespace piezo::daemon
