#include "log_writer.hpp"

#include <utility>

namespace piezo::host {

LogWriter::LogWriter(RunLog& log) : log_(log), thread_([this] { run(); }) {}

LogWriter::~LogWriter() {
  (void)finish();
}

namespace {
std::size_t drive_rows(const log_schema::AxesRows& rows) {
  std::size_t n = 0;
  for (const auto& axis : rows) n += axis.drive.t.size();
  return n;
}
}  // namespace

void LogWriter::submit(log_schema::AxesRows& rows) {
  {
    const std::lock_guard lock(mutex_);
    // After a failure nothing more is written; the loop sees error().
    if (!error_.empty()) return;
    pending_drive_rows_ += drive_rows(rows);
    queue_.emplace_back(std::exchange(rows, log_schema::AxesRows(rows.size())));
  }
  wake_.notify_one();
}

std::string LogWriter::error() const {
  const std::lock_guard lock(mutex_);
  return error_;
}

std::size_t LogWriter::pending_drive_rows() const {
  const std::lock_guard lock(mutex_);
  return pending_drive_rows_;
}

std::string LogWriter::finish() {
  {
    const std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_one();
  if (thread_.joinable()) thread_.join();
  return error();
}

void LogWriter::run() {
  for (;;) {
    log_schema::AxesRows batch;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [this] { return !queue_.empty() || stopping_; });
      if (queue_.empty()) return;  // stopping, and everything written
      batch = std::move(queue_.front());
      queue_.pop_front();
    }
    const std::size_t batch_drive_rows = drive_rows(batch);
    std::string failure;
    try {
      log_.append(batch);
    } catch (const std::exception& e) {
      failure = e.what();
    }
    const std::lock_guard lock(mutex_);
    pending_drive_rows_ -= batch_drive_rows;
    if (!failure.empty()) {
      error_ = failure;
      queue_.clear();
      pending_drive_rows_ = 0;
    }
  }
}

}  // namespace piezo::host
