#pragma once
// What `fetch` may cost, client by client: a token bucket of samples. Each
// client may take `rate` samples per second, in bursts up to `burst` (one
// largest fetch); beyond it a fetch is refused `rate_limited` with the wait.
// The daemon applies it to the clients that watch a run, not to the run's
// controller.
// A client flooding fetch then costs the network thread (and the board's
// memory bus, shared with the drive loop) a bounded amount, and every other
// client keeps its own budget.

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <string>
#include <unordered_map>

namespace piezo::daemon {

class FetchBudget {
 public:
  using Clock = std::chrono::steady_clock;

  FetchBudget(double samples_per_s, double burst) : rate_(samples_per_s), burst_(burst) {}

  /// Takes `samples` from `client`'s bucket; returns 0 when it had them,
  /// else the seconds until it will.
  double take(const std::string& client, double samples, Clock::time_point now = Clock::now()) {
    Bucket& b = bucket(client, now);
    b.tokens = std::min(burst_, b.tokens + rate_ * seconds(now - b.filled));
    b.filled = now;
    if (b.tokens >= samples) {
      b.tokens -= samples;
      return 0.0;
    }
    return (samples - b.tokens) / rate_;
  }

  /// Charges `client` `samples` more after the fact (the bucket may go
  /// below empty: the client then waits until it has refilled).
  void charge(const std::string& client, double samples, Clock::time_point now = Clock::now()) {
    Bucket& b = bucket(client, now);
    b.tokens -= samples;
  }

  [[nodiscard]] double samples_per_s() const { return rate_; }

 private:
  struct Bucket {
    double tokens;
    Clock::time_point filled;
  };
  static double seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

  Bucket& bucket(const std::string& client, Clock::time_point now) {
    // Clients come and go (each connection has its own routing id): buckets
    // that have filled up again hold nothing worth keeping.
    constexpr std::size_t kMaxClients = 1024;
    if (buckets_.size() >= kMaxClients && buckets_.find(client) == buckets_.end()) {
      std::erase_if(buckets_, [&](const auto& entry) {
        return entry.second.tokens + rate_ * seconds(now - entry.second.filled) >= burst_;
      });
    }
    return buckets_.try_emplace(client, Bucket{burst_, now}).first->second;
  }

  double rate_, burst_;
  std::unordered_map<std::string, Bucket> buckets_;
};

}  // namespace piezo::daemon
