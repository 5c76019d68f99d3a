#pragma once
// Min/max decimation for plotting: a pixel column shows the lowest and the
// highest sample that fell in it, so a spike or a sawtooth's corner is
// never averaged away, and a 10 kHz stream costs two points per column.

#include <cstddef>
#include <span>
#include <vector>

namespace piezo::host::view {

struct Series {
  std::vector<double> t, y;
};

/// The samples of (t, y) inside [t0, t1], at most two per column of
/// `columns` equal columns (its minimum and maximum, in time order).
/// NaN values (failed readings) are skipped. `t` must be non-decreasing.
[[nodiscard]] Series min_max_decimate(std::span<const double> t, std::span<const double> y,
                                      double t0, double t1, std::size_t columns);

}  // namespace piezo::host::view

namespace piezo::host::view {

/// Min/max decimation on a fixed grid: column k holds the samples with
/// floor(t / width) == k. Columns [first, end) are taken. Because the grid
/// does not move with the window, a column decimated now and the same column
/// decimated later give the same points: a page can append new columns to
/// the ones it holds and show what a fresh snapshot shows.
[[nodiscard]] Series min_max_columns(std::span<const double> t, std::span<const double> y,
                                     double width, long long first, long long end);

/// The grid column a time falls in.
[[nodiscard]] long long column_of(double t, double width);

}  // namespace piezo::host::view
