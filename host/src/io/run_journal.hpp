#pragma once
// The run log's write-ahead journal (run.journal beside run.h5). Every
// flush interval's rows reach the journal, and the disk (fdatasync),
// before HDF5 sees them: HDF5 killed inside a flush can leave its metadata
// half-written, an append-only journal cannot. After a crash, recover_run()
// (run_recovery.hpp) rebuilds a valid run.h5 from it and what run.h5
// kept, losing at most the last flush interval.
//
// The file is a sequence of blocks (the layout of a write-ahead log, as in
// PX4's ULog or SQLite's WAL):
//   u32 magic "PZJ1" | u8 kind | u32 stored length | u32 plain length |
//   u32 CRC-32 of kind, lengths and stored bytes | stored bytes (deflated)
// all little-endian. A block whose header or CRC does not check, and all
// after it, is the torn tail of a write the crash interrupted.
// Kinds: header (the log's opening attributes), rows (one flush: for each
// dataset its path and values), attribute (one set later in the run; an
// axis's under its group's path, "/axes/theta/summary").

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "log_schema.hpp"

namespace piezo::host {

class RunJournal {
 public:
  RunJournal() = default;
  /// Creates (truncates) the journal and writes its header block.
  static RunJournal create(const std::string& path,
                           const std::map<std::string, std::string>& header);
  RunJournal(RunJournal&& o) noexcept;
  RunJournal& operator=(RunJournal&& o) noexcept;
  RunJournal(const RunJournal&) = delete;
  RunJournal& operator=(const RunJournal&) = delete;
  ~RunJournal();

  /// Appends one flush interval's rows and waits for the disk. Throws
  /// naming the file when the write fails (the journal then ends with at
  /// most a torn block, which readers skip).
  /// `axes`: the log's (log_schema::axis_group), one LogRows each.
  void append(log_schema::AxesRows& rows, const std::vector<std::string>& axes);
  void set_attribute(const std::string& name, const std::string& value);
  /// The bytes a block holding `values` doubles would take at most.
  [[nodiscard]] static std::size_t bound(std::size_t values);
  /// Closes and deletes the journal: the HDF5 file holds everything.
  void remove();
  [[nodiscard]] const std::string& path() const { return path_; }

 private:
  void write_block(std::uint8_t kind, const std::string& plain);
  int fd_ = -1;
  std::string path_;
};

/// What a journal holds, up to its first damaged block.
struct JournalContents {
  std::map<std::string, std::string> header;
  std::map<std::string, std::string> attributes;
  /// The log's axes (its header's "axes"; one unnamed: a log of one), and
  /// one LogRows for each.
  std::vector<std::string> axes{""};
  log_schema::AxesRows rows = log_schema::AxesRows(1);
  std::size_t blocks = 0;         ///< whole blocks read
  std::uintmax_t torn_bytes = 0;  ///< bytes after the last whole block
};

/// Reads `path`; throws naming it when it is not a journal at all.
[[nodiscard]] JournalContents read_journal(const std::string& path);

/// The journal beside a run log.
[[nodiscard]] std::string journal_path(const std::string& log_path);

}  // namespace piezo::host
