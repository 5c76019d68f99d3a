#include "stream_follower.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <zmq_addon.hpp>

#include "piezo/firmware/wire_keys.hpp"
#include "piezo/protocol/message.hpp"
#include "piezo/protocol/topics.hpp"

namespace piezo::host {
namespace {

constexpr std::uint64_t kFetchChunk = 50'000;

}  // namespace

void StreamFollower::subscribe(BoardClient& client) {
  client.subscribe({protocol::topic::drive, protocol::topic::sensor, protocol::topic::state,
                    protocol::topic::health, protocol::topic::trigger});
  // A PUB socket drops what it publishes before a subscription reaches it:
  // wait for the board's health beat (every 250 ms), which shows the link
  // is up, for at most 2 s (as piezo_rig.board does).
  const auto deadline = SteadyClock::now() + std::chrono::seconds(2);
  while (SteadyClock::now() < deadline) {
    if (!poll_in(client.stream(), std::chrono::milliseconds(100))) continue;
    std::vector<zmq::message_t> parts;
    if (zmq::recv_multipart(client.stream(), std::back_inserter(parts),
                            zmq::recv_flags::dontwait) &&
        !parts.empty() && parts[0].to_string_view() == protocol::topic::health) {
      return;
    }
  }
}

void StreamFollower::follow(std::vector<SampleCollector*> by_axis,
                            std::function<double()> received_s, bool from_sample_zero) {
  collectors_ = std::move(by_axis);
  received_s_ = std::move(received_s);
  from_sample_zero_ = from_sample_zero;
  drive_started_ = sensor_started_ = false;
  drive_next_ = sensor_next_ = 0;
  gaps_.clear();
}

void StreamFollower::drain(std::chrono::milliseconds wait, int max_messages,
                           const Handlers& handlers) {
  if (!poll_in(client_.stream(), wait)) return;
  for (int i = 0; i < max_messages && (!handlers.keep_going || handlers.keep_going()); ++i) {
    std::vector<zmq::message_t> parts;
    if (!zmq::recv_multipart(client_.stream(), std::back_inserter(parts),
                             zmq::recv_flags::dontwait) ||
        parts.size() != 2) {
      break;
    }
    last_heard_ = SteadyClock::now();
    if (handlers.on_heard) handlers.on_heard();
    const std::string_view topic = parts[0].to_string_view();
    const std::string_view body = parts[1].to_string_view();
    if (topic == protocol::topic::health) {
      health_ = protocol::decode<protocol::HealthEvent>(protocol::decode_map(body));
      if (handlers.on_health) handlers.on_health(health_);
    } else if (topic == protocol::topic::state) {
      const auto state = protocol::decode<protocol::StateEvent>(protocol::decode_map(body));
      if (handlers.on_state) handlers.on_state(state);
    } else if (topic == protocol::topic::trigger) {
      const auto pulse = protocol::decode<protocol::TriggerEvent>(protocol::decode_map(body));
      if (handlers.on_trigger) handlers.on_trigger(pulse);
    } else if (!collectors_.empty()) {
      on_frame(body, handlers);
    }
  }
}

void StreamFollower::on_frame(std::string_view frame, const Handlers& handlers) {
  const auto header = protocol::decode_header(frame);
  const bool drive = header.stream == protocol::Stream::drive;
  bool& started = drive ? drive_started_ : sensor_started_;
  if (!started && !from_sample_zero_) {
    // A watcher joining a run under way starts where each stream is.
    (drive ? drive_next_ : sensor_next_) = header.first_seq;
  }
  started = true;
  const std::uint64_t next = header.stream == protocol::Stream::drive ? drive_next_ : sensor_next_;
  if (header.first_seq > next) {
    if (handlers.before_fetch) handlers.before_fetch();
    fetch(header.stream, header.first_seq);
  }
  add(frame, header);
}

void StreamFollower::fetch(protocol::Stream stream, std::uint64_t end) {
  if (collectors_.empty()) return;
  std::uint64_t& next = stream == protocol::Stream::drive ? drive_next_ : sensor_next_;
  if (next < end) {
    gaps_.push_back(fmt::format("{} [{}, {})", protocol::to_string(stream), next, end));
  }
  while (next < end) {
    nlohmann::json r;
    try {
      r = call_("fetch", protocol::FetchRequest{stream, next, std::min(kFetchChunk, end - next)});
    } catch (const RemoteError& e) {
      if (from_sample_zero_) throw;  // the controller's log must not miss a sample
      gaps_.back() += fmt::format(" (not fetched: {})", e.what());
      next = end;
      return;
    }
    const auto reply = protocol::decode<protocol::FetchReply>(r);
    const auto& bytes = reply.frame.get_binary();
    const std::string frame(bytes.begin(), bytes.end());
    const auto header = protocol::decode_header(frame);
    if (header.count == 0) break;
    add(frame, header);
  }
}

void StreamFollower::add(std::string_view frame, const protocol::FrameHeader& h) {
  std::uint64_t& next = h.stream == protocol::Stream::drive ? drive_next_ : sensor_next_;
  if (h.first_seq > next || h.first_seq + h.count <= next) return;  // a gap left, or a repeat
  const std::size_t skip = next - h.first_seq;
  const double received = received_s_();
  for (SampleCollector* c : collectors_)
    if (c != nullptr) c->set_received(received);
  const auto add_all = [&](const auto& samples) {
    for (std::size_t i = skip; i < samples.size(); ++i) {
      if (SampleCollector* c = collector(samples[i].axis)) c->add(samples[i]);
    }
  };
  if (h.stream == protocol::Stream::drive) {
    add_all(protocol::decode_drive(frame));
  } else {
    add_all(protocol::decode_sensor(frame));
  }
  next = h.first_seq + h.count;
}

}  // namespace piezo::host
