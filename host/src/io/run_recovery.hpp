#pragma once
// Recovery of a crashed or damaged run: run.h5 and its journal
// (run_journal.hpp) are two copies of one stream of rows, each whole up to
// where it was cut (the journal at its torn tail, run.h5 at its last flush
// or its first damaged chunk). Recovery reads both as far as each goes and
// keeps, row by row, the journal's value (CRC-checked) where it has the
// row, else run.h5's: it never keeps less than either
// copy held, and where it keeps less than a copy claimed (a damaged chunk
// with no other copy of its rows) it says so.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace piezo::host {

struct Recovery {
  bool rebuilt = false;  ///< false: run.h5 was already whole
  std::string status;    ///< run.h5's status afterwards
  std::size_t drive_rows = 0, sensor_rows = 0, observer_rows = 0;  ///< kept
  std::size_t trigger_rows = 0;                                    ///< a scan's trigger pulses kept
  std::size_t blocks = 0;                                          ///< the journal's whole blocks
  std::uintmax_t torn_bytes = 0;                                   ///< the journal's torn tail
  std::string damaged;  ///< where the replaced run.h5 was kept, if any
  /// What was found and could not be kept, one sentence each: a group that
  /// kept fewer rows than a copy claimed, or values lost in a damaged chunk.
  std::vector<std::string> losses;
  [[nodiscard]] bool kept_less() const { return !losses.empty(); }
};

/// Makes `run_dir`/run.h5 whole. Nothing to do when every dataset of it
/// reads, its status is final and the journal, if any, holds no more rows.
/// Otherwise writes the merge of both copies as run.h5, marked "recovered"
/// (the old file kept as run.h5.damaged), deletes the journal and adds the
/// run to the catalogue. Throws ConfigError when neither copy can be read.
Recovery recover_run(const std::string& run_dir);

/// For readers (report, identify, compare): recovers the run at `log_path`
/// first when a journal is there and run.h5 is not whole; says so on stderr.
void recover_if_needed(const std::string& log_path);

}  // namespace piezo::host
