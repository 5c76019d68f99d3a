#include "log_writer.hpp"

#include <utility>

namespace piezo::host {

LogWriter::LogWriter(RunLog& log) : log_(log), thread_([this] { run(); }) {}

LogWriter::~LogWriter() {
  (void)finish();
}

void LogWriter::submit(log_schema::LogRows& rows) {
  {
    const std::lock_guard lock(mutex_);
    // After a failure nothing more is written; the loop sees error().
    if (!error_.empty()) return;
    queue_.emplace_back(std::exchange(rows, log_schema::LogRows{}));
  }
  wake_.notify_one();
}

std::string LogWriter::error() const {
  const std::lock_guard lock(mutex_);
  return error_;
}

std::size_t LogWriter::backlog() const {
  const std::lock_guard lock(mutex_);
  return queue_.size() + (writing_ ? 1 : 0);
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
    log_schema::LogRows batch;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [this] { return !queue_.empty() || stopping_; });
      if (queue_.empty()) return;  // stopping, and everything written
      batch = std::move(queue_.front());
      queue_.pop_front();
      writing_ = true;
    }
    std::string failure;
    try {
      log_.append(batch);
    } catch (const std::exception& e) {
      failure = e.what();
    }
    const std::lock_guard lock(mutex_);
    writing_ = false;
    if (!failure.empty()) {
      error_ = failure;
      queue_.clear();
    }
  }
}

}  // namespace piezo::host
