#pragma once
// Writes a run's log on its own thread. The host's loop renews the board's
// lease and drains the stream; a log flush waits for the disk (the
// journal's fdatasync, HDF5's flush), which on a busy or slow disk can take
// longer than the lease. So the loop only hands each flush interval's rows
// over and goes on; this thread writes them in order.

#include <condition_variable>
#include <deque>
#include <mutex>
#include <string>
#include <thread>

#include "io/run_log.hpp"

namespace piezo::host {

class LogWriter {
 public:
  /// Writes to `log`, which nothing else may touch until finish().
  explicit LogWriter(RunLog& log);
  ~LogWriter();
  LogWriter(const LogWriter&) = delete;
  LogWriter& operator=(const LogWriter&) = delete;

  /// Takes the rows (one LogRows per axis of the log, each left empty) to
  /// be appended in order.
  void submit(log_schema::AxesRows& rows);
  /// The first write's failure, empty while all is well.
  [[nodiscard]] std::string error() const;
  /// Drive rows handed over and not yet written: the loop acknowledges to
  /// the board only what is logged (on the virtual clock the board waits).
  [[nodiscard]] std::size_t pending_drive_rows() const;
  /// Writes what is queued and stops the thread; the log is the caller's
  /// again. Returns error().
  std::string finish();

 private:
  void run();
  RunLog& log_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<log_schema::AxesRows> queue_;
  std::string error_;
  std::size_t pending_drive_rows_ = 0;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace piezo::host
