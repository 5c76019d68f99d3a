#pragma once
// Named columns of equal length, written as CSV (header row) or as 1-D
// HDF5 datasets under one group.

#include <span>
#include <string>
#include <vector>

namespace piezo::host {

struct Column {
  std::string name;
  std::span<const double> values;
};

/// Writes a CSV with a header row of column names; throws on I/O failure.
void write_csv(const std::string& path, const std::vector<Column>& columns);

/// Writes text already formatted (e.g. a table with a column of names);
/// throws on I/O failure.
void write_text(const std::string& path, const std::string& text);

}  // namespace piezo::host
