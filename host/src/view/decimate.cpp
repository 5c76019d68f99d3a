#include "decimate.hpp"

#include <algorithm>
#include <cmath>

namespace piezo::host::view {

Series min_max_decimate(std::span<const double> t, std::span<const double> y, double t0, double t1,
                        std::size_t columns) {
  Series out;
  if (t.empty() || columns == 0 || !(t1 > t0)) return out;
  const double width = (t1 - t0) / static_cast<double>(columns);
  // One formula decides a sample's column, so every sample falls in exactly
  // one (a boundary computed separately could disagree with it by a rounding).
  const auto column_of = [&](double ti) {
    return std::min(columns - 1, static_cast<std::size_t>((ti - t0) / width));
  };
  auto i = static_cast<std::size_t>(std::lower_bound(t.begin(), t.end(), t0) - t.begin());
  const std::size_t n = std::min(t.size(), y.size());
  while (i < n && t[i] <= t1) {
    const std::size_t column = column_of(t[i]);
    std::size_t lo = n, hi = n;
    for (; i < n && t[i] <= t1 && column_of(t[i]) == column; ++i) {
      if (std::isnan(y[i])) continue;
      if (lo == n || y[i] < y[lo]) lo = i;
      if (hi == n || y[i] > y[hi]) hi = i;
    }
    if (lo == n) continue;
    const std::size_t first = std::min(lo, hi), second = std::max(lo, hi);
    out.t.push_back(t[first]);
    out.y.push_back(y[first]);
    if (second != first) {
      out.t.push_back(t[second]);
      out.y.push_back(y[second]);
    }
  }
  return out;
}

}  // namespace piezo::host::view

namespace piezo::host::view {

long long column_of(double t, double width) {
  return static_cast<long long>(std::floor(t / width));
}

Series min_max_columns(std::span<const double> t, std::span<const double> y, double width,
                       long long first, long long end) {
  Series out;
  const std::size_t n = std::min(t.size(), y.size());
  // Starts a little before the first column's edge: the column is decided
  // by column_of alone, never by a separately computed boundary.
  auto i = static_cast<std::size_t>(std::lower_bound(t.begin(),
                                                     t.begin() + static_cast<std::ptrdiff_t>(n),
                                                     (static_cast<double>(first) - 1.0) * width) -
                                    t.begin());
  while (i < n && column_of(t[i], width) < first) ++i;
  while (i < n) {
    const long long column = column_of(t[i], width);
    if (column >= end) break;
    std::size_t lo = n, hi = n;
    for (; i < n && column_of(t[i], width) == column; ++i) {
      if (std::isnan(y[i])) continue;
      if (lo == n || y[i] < y[lo]) lo = i;
      if (hi == n || y[i] > y[hi]) hi = i;
    }
    if (lo == n) continue;
    const std::size_t a = std::min(lo, hi), b = std::max(lo, hi);
    out.t.push_back(t[a]);
    out.y.push_back(y[a]);
    if (b != a) {
      out.t.push_back(t[b]);
      out.y.push_back(y[b]);
    }
  }
  return out;
}

}  // namespace piezo::host::view
