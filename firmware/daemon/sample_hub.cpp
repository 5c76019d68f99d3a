#include "sample_hub.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <vector>
#include <zmq_addon.hpp>

#include "piezo/firmware/wire_keys.hpp"
#include "piezo/protocol/error.hpp"
#include "piezo/protocol/frame.hpp"
#include "piezo/protocol/message.hpp"
#include "piezo/protocol/messages.hpp"
#include "piezo/protocol/topics.hpp"

namespace piezo::daemon {
namespace {

using nlohmann::json;
using protocol::ProtocolError;
namespace code = protocol::code;

constexpr std::size_t kMaxBatch = 2000;  // samples per published frame

json binary(const std::string& frame) {
  return json::binary(std::vector<std::uint8_t>(frame.begin(), frame.end()));
}

}  // namespace

SampleHub::SampleHub(double recorder_s, double drive_rate_hz, double sensor_rate_hz,
                     const std::string& spill_file, double fetch_samples_per_s,
                     zmq::socket_t& stream)
    : drive_(static_cast<std::size_t>(recorder_s * drive_rate_hz)),
      sensor_(static_cast<std::size_t>(recorder_s * sensor_rate_hz)),
      budget_(fetch_samples_per_s, static_cast<double>(kMaxFetch)),
      stream_(stream) {
  if (!spill_file.empty()) spill_.emplace(spill_file);
}

void SampleHub::clear() {
  drive_.clear();
  sensor_.clear();
  if (spill_) spill_->clear();
  drive_published_ = sensor_published_ = 0;
}

void SampleHub::take(firmware::LoopRunner& runner,
                     const std::function<void(const firmware::DriveSample&)>& on_drive,
                     const std::function<void(std::uint8_t, double)>& on_good_reading) {
  for (std::size_t axis = 0; axis < runner.axis_count(); ++axis) {
    runner.drain(
        axis,
        [&](const firmware::DriveSample& s) {
          drive_.push(s);
          on_drive(s);
        },
        [&](const firmware::SensorSample& s) {
          sensor_.push(s);
          if (s.status == hal::Status::ok) on_good_reading(s.axis, s.displacement_m);
        });
  }
  publish(protocol::topic::drive, drive_, drive_published_);
  publish(protocol::topic::sensor, sensor_, sensor_published_);
}

template <class Sample>
void SampleHub::publish(std::string_view topic, const Recorder<Sample>& recorder,
                        std::uint64_t& published) {
  std::vector<Sample> batch;
  while (published < recorder.next()) {
    published = std::max(published, recorder.first());
    recorder.copy(published, kMaxBatch, batch);
    if (batch.empty()) break;
    const std::string frame = protocol::encode_frame(published, batch);
    if (spill_) spill_->append(frame);
    std::array<zmq::const_buffer, 2> parts{zmq::buffer(topic), zmq::buffer(frame)};
    (void)zmq::send_multipart(stream_, parts, zmq::send_flags::dontwait);
    published += batch.size();
  }
}

json SampleHub::fetch(const std::string& client, const json& args, bool budgeted) {
  const auto [stream, first, count] = protocol::decode<protocol::FetchRequest>(args);
  if (count > kMaxFetch) {
    throw ProtocolError(code::out_of_limits, wire_key::count,
                        fmt::format("count: {}; allowed: at most {} per fetch", count, kMaxFetch));
  }
  // A watcher's fetches cost the run a bounded amount; the controller's gap
  // filling (which its own lease waits on) is not budgeted.
  if (const double wait_s = budgeted ? budget_.take(client, static_cast<double>(count)) : 0.0;
      wait_s > 0) {
    throw ProtocolError(code::rate_limited, wire_key::count,
                        fmt::format("fetch: over this client's budget of {:g} samples/s; "
                                    "retry in {:.3f} s",
                                    budget_.samples_per_s(), wait_s));
  }
  // And by the network thread's time it takes: where serving is slower than
  // the budget assumes (a slow board, a sanitizer build), a watcher could
  // keep the thread busy within its samples, and the controller's lease
  // would wait behind it. A watcher's fetches may take a quarter of it.
  constexpr double kWatcherShare = 0.25;
  const auto served_from = std::chrono::steady_clock::now();
  struct ChargeTime {
    ~ChargeTime() {
      if (!budgeted) return;
      const double took_s =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - from).count();
      const double as_samples = took_s * hub.budget_.samples_per_s() / kWatcherShare;
      if (as_samples > asked) hub.budget_.charge(client, as_samples - asked);
    }
    SampleHub& hub;
    const std::string& client;
    bool budgeted;
    std::chrono::steady_clock::time_point from;
    double asked;
  } charge_time{*this, client, budgeted, served_from, static_cast<double>(count)};
  const bool drive = stream == protocol::Stream::drive;
  const std::uint64_t held_first = drive ? drive_.first() : sensor_.first();
  const std::uint64_t held_next = drive ? drive_.next() : sensor_.next();
  if (spill_ && first < held_first) {
    // Past the memory ring: the spill file has it.
    if (auto frame = spill_->fetch(stream, first, count))
      return protocol::FetchReply{binary(*frame)};
  }
  if (first < held_first || first > held_next) {
    throw ProtocolError(code::not_available, wire_key::first,
                        fmt::format("first: {} is not recorded; the recorder holds [{}, {})", first,
                                    held_first, held_next));
  }
  if (drive) {
    std::vector<firmware::DriveSample> samples;
    drive_.copy(first, count, samples);
    return protocol::FetchReply{binary(protocol::encode_frame(first, samples))};
  }
  std::vector<firmware::SensorSample> samples;
  sensor_.copy(first, count, samples);
  return protocol::FetchReply{binary(protocol::encode_frame(first, samples))};
}

}  // namespace piezo::daemon
