#pragma once
// Runs independent jobs on all cores, reporting progress from the calling
// thread only (so stderr lines never interleave).

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdlib>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "interruption.hpp"

namespace piezo::host {

/// Calls job(i) for i in [0, count) on up to hardware_concurrency threads and
/// progress(done, count) every 20 ms while jobs finish, and once more as soon
/// as the last has. The first exception thrown
/// by a job is rethrown once all threads have stopped. An interruption
/// (interruption.hpp), or a progress call that throws, stops the jobs not
/// yet begun and those under way at their next interruption_point() (a
/// simulation reaches one every few milliseconds); it is rethrown once
/// the threads have stopped.
inline void parallel_for(std::size_t count, const std::function<void(std::size_t)>& job,
                         const std::function<void(std::size_t, std::size_t)>& progress) {
  std::atomic<std::size_t> next{0};
  std::exception_ptr failure;
  // The caller's thread reports progress every 20 ms (and checks for an
  // interruption) and wakes as soon as the last job is done: it used to
  // poll, which added up to 20 ms to every call (identify makes several an
  // iteration).
  std::mutex mutex;  // guards done and failure
  std::condition_variable finished;
  std::size_t done = 0;
  std::atomic<bool> stopped{false};
  auto worker = [&] {
    jobs_stopped = &stopped;
    for (std::size_t i = next++; i < count; i = next++) {
      std::exception_ptr thrown;
      try {
        job(i);
      } catch (...) {
        thrown = std::current_exception();
      }
      bool last = false;
      {
        std::lock_guard lock(mutex);
        if (thrown && !failure) failure = thrown;
        last = ++done == count;
      }
      if (last) finished.notify_one();
    }
    jobs_stopped = nullptr;
  };
  // PIEZO_THREADS caps the threads (e.g. one per MPI rank on a shared node).
  std::size_t cores = std::thread::hardware_concurrency();
  if (const char* cap = std::getenv("PIEZO_THREADS"); cap != nullptr && std::atoi(cap) > 0) {
    cores = static_cast<std::size_t>(std::atoi(cap));
  }
  const std::size_t n_threads = std::max<std::size_t>(1, std::min<std::size_t>(count, cores));
  std::vector<std::thread> threads;
  for (std::size_t t = 0; t < n_threads; ++t) threads.emplace_back(worker);
  std::size_t reported = 0;
  std::exception_ptr interrupted;
  while (reported < count) {
    try {
      interruption_point();
      std::size_t now = 0;
      {
        std::unique_lock lock(mutex);
        finished.wait_for(lock, std::chrono::milliseconds(20), [&] { return done == count; });
        now = done;
      }
      if (now != reported) {
        reported = now;
        progress(reported, count);
      }
    } catch (...) {
      interrupted = std::current_exception();
      next = count;    // the workers take no further job
      stopped = true;  // and leave the ones under way
      break;
    }
  }
  for (auto& t : threads) t.join();
  if (interrupted) std::rethrow_exception(interrupted);
  if (failure) std::rethrow_exception(failure);
}

}  // namespace piezo::host
