#pragma once
// The HDF5 log of one run. Samples are buffered by the host and appended
// every flush interval: first to the journal (run_journal.hpp, on the disk
// before HDF5 sees them), then to the file, each append followed by a
// flush. A crash or kill -9, even inside HDF5's flush, loses at most the
// samples of the last interval: `piezo recover` rebuilds the file from the
// journal. The journal is deleted once the file is closed whole. The root
// attribute "status" reads "incomplete" until the run closes the log with
// "completed", "interrupted" or "failed".
//
// The layout is log_schema.hpp's.

#include <cstdint>
#include <functional>
#include <map>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "h5_file.hpp"
#include "log_schema.hpp"
#include "run_journal.hpp"

namespace piezo::host {

using log_schema::AxesRows;
using log_schema::LogRows;

/// The log refused a write for want of room; the file is still whole.
class RoomError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class RunLog {
 public:
  /// Creates the file, its datasets and the header attributes, and flushes.
  /// `axes`: the run's axes, at least one, each under its group
  /// /axes/NAME (log_schema.hpp), the header's "axes" naming them. Only a
  /// log recovered from one written before this layout has the one unnamed
  /// axis "" (at the root, as it was).
  static RunLog create(const std::string& path, std::map<std::string, std::string> header,
                       const std::vector<std::string>& axes);

  /// The run's axes as create() took them.
  [[nodiscard]] const std::vector<std::string>& axes() const { return axes_; }

  /// Appends the buffered columns (one LogRows per axis, in axes() order),
  /// clears them and flushes the file, in slices. Refuses a slice (throws RoomError, the file still
  /// whole and closable, the slices before it written and removed from the buffer) when the device
  /// or the file-size limit leaves too little room for it plus a reserve for the close: a log that
  /// runs out of space half-way through a flush is left inconsistent by HDF5. Any other failure
  /// marks the log broken.
  void append(AxesRows& rows);
  /// The same for a log of one axis.
  void append(LogRows& rows);
  /// True once a write failed half-way: the file must not be written again.
  [[nodiscard]] bool broken() const { return broken_; }
  /// Writes a dataset whole (e.g. a timing histogram).
  void write(const std::string& name, std::span<const double> values);
  void set_attribute(const std::string& name, const std::string& value);
  /// Sets an attribute of axis `axis` (its group's in a log of several;
  /// the root's in a log of one).
  void set_axis_attribute(std::size_t axis, const std::string& name, const std::string& value);
  /// Marks the log with its final status and closes it; throws when that
  /// fails (the file is closed either way).
  void close(const std::string& status);
  /// Closes a log that can no longer be written, ignoring failures: what
  /// was flushed before stays readable, marked "incomplete".
  void abandon() noexcept;

 private:
  RunLog(H5File file, RunJournal journal, std::vector<std::string> axes)
      : file_(std::move(file)), journal_(std::move(journal)), axes_(std::move(axes)) {}
  void check_room(const std::string& path, std::uintmax_t bytes) const;
  H5File file_;
  RunJournal journal_;
  std::vector<std::string> axes_;
  bool broken_ = false;
  bool refused_ = false;  ///< rows the file refused are only in the journal
};

}  // namespace piezo::host
