#pragma once
/// @file
/// A bounded single-producer single-consumer ring: the only way samples
/// leave a real-time loop. Wait-free on both sides; a full ring refuses the
/// sample (the producer counts the drop) instead of blocking.

#include <atomic>
#include <cstddef>
#include <memory>
#include <new>
#include <type_traits>

namespace piezo::firmware {

template <class T>
class SpscRing {
  static_assert(std::is_trivially_copyable_v<T>, "samples are copied, never constructed in place");

 public:
  /// Capacity is rounded up to a power of two; storage is allocated here, once.
  explicit SpscRing(std::size_t capacity)
      : mask_(round_up_pow2(capacity) - 1), slots_(std::make_unique<T[]>(mask_ + 1)) {}

  SpscRing(const SpscRing&) = delete;
  SpscRing& operator=(const SpscRing&) = delete;

  /// Producer side. False when full.
  [[nodiscard]] bool try_push(const T& value) {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_cache_ > mask_) {
      tail_cache_ = tail_.load(std::memory_order_acquire);
      if (head - tail_cache_ > mask_) return false;
    }
    slots_[head & mask_] = value;
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  /// Consumer side. False when empty.
  [[nodiscard]] bool try_pop(T& out) {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_cache_) {
      head_cache_ = head_.load(std::memory_order_acquire);
      if (tail == head_cache_) return false;
    }
    out = slots_[tail & mask_];
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  /// Consumer side: hands every available sample to `sink`, returns how many.
  template <class Sink>
  std::size_t drain(Sink&& sink) {
    std::size_t n = 0;
    T value;
    while (try_pop(value)) {
      sink(value);
      ++n;
    }
    return n;
  }

  [[nodiscard]] std::size_t capacity() const { return mask_ + 1; }
  /// Samples waiting, as seen at this moment from any thread (approximate).
  [[nodiscard]] std::size_t size_approx() const {
    // Tail first: the head read after it is never behind it.
    const std::size_t tail = tail_.load(std::memory_order_acquire);
    return head_.load(std::memory_order_acquire) - tail;
  }

 private:
  static std::size_t round_up_pow2(std::size_t n) {
    std::size_t p = 1;
    while (p < n) p <<= 1;
    return p;
  }

  // Producer and consumer indices on separate cache lines: avoid false sharing.
  static constexpr std::size_t kLine = 64;
  const std::size_t mask_;
  const std::unique_ptr<T[]> slots_;
  alignas(kLine) std::atomic<std::size_t> head_{0};
  std::size_t tail_cache_ = 0;  // producer's last view of tail_
  alignas(kLine) std::atomic<std::size_t> tail_{0};
  std::size_t head_cache_ = 0;  // consumer's last view of head_
};

}  // namespace piezo::firmware
