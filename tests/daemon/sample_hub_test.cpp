// SampleHub, where a run's samples go on the board: each sample the loops
// produced reaches the stream and the recorder once, in order, numbered
// from 0; `fetch` answers from memory, or from the spill file once the
// memory ring has moved on, and refuses what is not recorded, too large a
// count and a watcher over its budget, naming the argument.

#include "daemon/sample_hub.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <thread>
#include <utility>
#include <vector>
#include <zmq.hpp>
#include <zmq_addon.hpp>

#include "piezo/firmware/loop_runner.hpp"
#include "piezo/hal/posix/monotonic_clock.hpp"
#include "piezo/hal/posix/no_lines.hpp"
#include "piezo/hal/sim/null_drive.hpp"
#include "piezo/hal/sim/null_sensor.hpp"
#include "piezo/model/waveform.hpp"
#include "piezo/protocol/error.hpp"
#include "piezo/protocol/frame.hpp"

namespace piezo::daemon {
namespace {

constexpr double kRateHz = 1000.0;

/// A stream subscriber that is known to be subscribed before anything is
/// published (XPUB hands the subscription to the publisher first).
struct Stream {
  zmq::context_t context;
  zmq::socket_t pub{context, zmq::socket_type::xpub};
  zmq::socket_t sub{context, zmq::socket_type::sub};
  Stream() {
    const std::string address = "inproc://hub-" + std::to_string(::getpid());
    pub.bind(address);
    sub.connect(address);
    sub.set(zmq::sockopt::subscribe, "");
    zmq::message_t subscription;
    (void)pub.recv(subscription);
  }
  /// Every published (topic, frame), in order.
  std::vector<std::pair<std::string, std::string>> frames() {
    std::vector<std::pair<std::string, std::string>> out;
    std::vector<zmq::message_t> parts;
    while (zmq::recv_multipart(sub, std::back_inserter(parts), zmq::recv_flags::dontwait)) {
      if (parts.size() == 2) out.emplace_back(parts[0].to_string(), parts[1].to_string());
      parts.clear();
    }
    return out;
  }
};

/// A short run of the real loops on null devices, its samples taken into
/// `hub` while it runs, as piezod's network thread does (nothing is timed:
/// only what the loops produced is compared).
void run_into(SampleHub& hub, double seconds, const std::function<void(double)>& on_good = {}) {
  hal::posix::MonotonicClock clock;
  hal::sim::NullDrive drive{clock};
  hal::sim::NullSensor sensor{clock};
  hal::posix::NoLines lines;
  const model::Sawtooth saw{10.0, 20.0, 0.75};
  firmware::WaveformProgram program{saw};
  firmware::LoopRunnerSettings s;
  s.drive = {kRateHz, seconds};
  s.sensor_rate_hz = kRateHz;
  s.realtime = false;
  std::vector<firmware::RunAxis> axes{
      {drive, sensor, program, {0.0, 80.0, 20'000.0}, 0.05, firmware::SafetySettings{}}};
  firmware::LoopRunner runner(s, std::move(axes), clock, lines);
  const auto good = [&](std::uint8_t, double x) {
    if (on_good) on_good(x);
  };
  const auto on_drive = [](const firmware::DriveSample&) {};
  (void)runner.start({});
  while (!runner.finished()) {
    hub.take(runner, on_drive, good);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  runner.join();
  hub.take(runner, on_drive, good);
}

/// What the stream carried, by topic, in order.
struct Published {
  std::vector<firmware::DriveSample> drive;
  std::vector<firmware::SensorSample> sensor;
  std::vector<std::pair<std::uint64_t, std::size_t>> drive_frames;  ///< (first, count)
};

Published published(Stream& stream) {
  Published out;
  for (const auto& [topic, frame] : stream.frames()) {
    if (topic == "drive") {
      const auto samples = protocol::decode_drive(frame);
      out.drive_frames.emplace_back(protocol::decode_header(frame).first_seq, samples.size());
      out.drive.insert(out.drive.end(), samples.begin(), samples.end());
    } else {
      const auto samples = protocol::decode_sensor(frame);
      out.sensor.insert(out.sensor.end(), samples.begin(), samples.end());
    }
  }
  return out;
}

/// fetch's arguments as a client's MessagePack brings them (unsigned).
nlohmann::json fetch_args(const char* stream, std::uint64_t first, std::uint64_t count) {
  return {{"stream", stream}, {"first", first}, {"count", count}};
}

std::string frame_of(const nlohmann::json& reply) {
  const auto& bytes = reply.at("frame").get_binary();
  return {bytes.begin(), bytes.end()};
}

TEST(SampleHub, EachSampleIsPublishedAndRecordedOnceInOrder) {
  Stream stream;
  SampleHub hub(10.0, kRateHz, kRateHz, "", 1e6, stream.pub);
  int good = 0;
  run_into(hub, 0.2, [&](double) { ++good; });
  const Published out = published(stream);
  std::uint64_t next = 0;
  for (const auto& [first, count] : out.drive_frames) {
    ASSERT_EQ(first, next) << "no gap, no repeat";
    next += count;
  }
  ASSERT_GT(out.drive.size(), 100u);
  EXPECT_EQ(out.drive.size(), hub.drive_recorded());
  EXPECT_EQ(hub.drive_first(), 0u);
  for (std::size_t i = 1; i < out.drive.size(); ++i) {
    ASSERT_GT(out.drive[i].t, out.drive[i - 1].t) << "sample " << i;
  }
  EXPECT_EQ(out.sensor.size(), hub.sensor_recorded());
  EXPECT_EQ(static_cast<std::uint64_t>(good), hub.sensor_recorded())
      << "every null reading is good";

  // fetch from memory gives the very samples the stream carried.
  const auto reply = hub.fetch("c", fetch_args("drive", 10, 20), false);
  const auto fetched = protocol::decode_drive(frame_of(reply));
  ASSERT_EQ(fetched.size(), 20u);
  for (std::size_t i = 0; i < fetched.size(); ++i) {
    EXPECT_EQ(fetched[i].t, out.drive[10 + i].t);
    EXPECT_EQ(fetched[i].V, out.drive[10 + i].V);
  }

  // A new run numbers from 0 again.
  hub.clear();
  EXPECT_EQ(hub.drive_recorded(), 0u);
}

TEST(SampleHub, FetchRefusesWhatItCannotGiveNamingTheArgument) {
  Stream stream;
  SampleHub hub(10.0, kRateHz, kRateHz, "", 500.0, stream.pub);
  run_into(hub, 0.1);
  const auto refused = [&](const nlohmann::json& args, bool budgeted) -> protocol::ProtocolError {
    try {
      (void)hub.fetch("watcher", args, budgeted);
    } catch (const protocol::ProtocolError& e) {
      return e;
    }
    ADD_FAILURE() << "accepted " << args.dump();
    return {"", "", ""};
  };
  const auto past = refused(fetch_args("drive", hub.drive_recorded() + 1, 1), false);
  EXPECT_EQ(past.code(), protocol::code::not_available);
  EXPECT_EQ(past.key(), "first");
  const auto huge = refused(fetch_args("sensor", 0, SampleHub::kMaxFetch + 1), false);
  EXPECT_EQ(huge.code(), protocol::code::out_of_limits);
  EXPECT_EQ(huge.key(), "count");
  // A watcher's budget (500 samples/s here, a burst of one full fetch): its
  // first fetch passes, then it is told to wait; the controller's gap
  // filling is never budgeted.
  const nlohmann::json some = fetch_args("drive", 0, SampleHub::kMaxFetch);
  std::string code;
  for (int i = 0; i < 3 && code.empty(); ++i) {
    try {
      (void)hub.fetch("watcher", some, true);
    } catch (const protocol::ProtocolError& e) {
      code = e.code();
      EXPECT_EQ(e.key(), "count");
    }
  }
  EXPECT_EQ(code, protocol::code::rate_limited);
  EXPECT_NO_THROW((void)hub.fetch("controller", some, false));
}

TEST(SampleHub, PastTheMemoryRingTheSpillFileAnswers) {
  const auto spill = std::filesystem::temp_directory_path() /
                     ("piezo-sample-hub-" + std::to_string(::getpid()) + ".spill");
  Stream stream;
  // 50 ms of memory for a 0.5 s run: the ring moves on, the file keeps
  // every frame the stream carried.
  SampleHub hub(0.05, kRateHz, kRateHz, spill.string(), 1e6, stream.pub);
  run_into(hub, 0.5);
  const Published out = published(stream);
  ASSERT_FALSE(out.drive_frames.empty());
  const std::uint64_t first = out.drive_frames.front().first;
  ASSERT_LT(first, hub.drive_first()) << "the ring has moved on past the first frame";
  const auto reply = hub.fetch("c", fetch_args("drive", first, 10), false);
  const auto fetched = protocol::decode_drive(frame_of(reply));
  ASSERT_EQ(fetched.size(), 10u);
  for (std::size_t i = 0; i < fetched.size(); ++i) EXPECT_EQ(fetched[i].t, out.drive[i].t);
  std::filesystem::remove(spill);
}

}  // namespace
}  // namespace piezo::daemon
