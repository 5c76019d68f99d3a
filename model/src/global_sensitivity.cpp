#include "piezo/model/global_sensitivity.hpp"

#include <algorithm>
#include <boost/random/sobol.hpp>
#include <boost/random/uniform_01.hpp>
#include <cmath>
#include <numeric>
#include <random>
#include <stdexcept>

namespace piezo::model {
namespace {

double scale(const Factor& f, double u) {
  return f.low + (f.high - f.low) * u;
}

double percentile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(pos);
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

/// S_i and ST_i over the points `idx` (indices into each block).
void estimate(std::span<const double> y, std::size_t n, std::size_t k,
              const std::vector<std::size_t>& idx, std::vector<double>& first,
              std::vector<double>& total, double& variance) {
  const auto A = [&](std::size_t j) { return y[j]; };
  const auto B = [&](std::size_t j) { return y[n + j]; };
  const auto E = [&](std::size_t i, std::size_t j) { return y[(2 + i) * n + j]; };
  const double m = static_cast<double>(idx.size());
  double mean = 0.0;
  for (std::size_t j : idx) mean += A(j) + B(j);
  mean /= 2.0 * m;
  variance = 0.0;
  for (std::size_t j : idx)
    variance += (A(j) - mean) * (A(j) - mean) + (B(j) - mean) * (B(j) - mean);
  variance /= 2.0 * m - 1.0;
  first.assign(k, 0.0);
  total.assign(k, 0.0);
  for (std::size_t i = 0; i < k; ++i) {
    double s = 0.0, t = 0.0;
    for (std::size_t j : idx) {
      // Saltelli 2010, on outputs centred by their mean: the same
      // expectation, far less variance when the mean dwarfs the spread.
      s += (B(j) - mean) * (E(i, j) - A(j));
      t += (A(j) - E(i, j)) * (A(j) - E(i, j));  // Jansen 1999
    }
    first[i] = s / m / variance;
    total[i] = t / (2.0 * m) / variance;
  }
}

}  // namespace

DesignRows saltelli_design(const std::vector<Factor>& factors, std::size_t n, std::uint64_t skip) {
  const std::size_t k = factors.size();
  if (k == 0 || n == 0) throw std::invalid_argument("saltelli_design: no factors or no samples");
  boost::random::sobol engine(static_cast<unsigned>(2 * k));
  engine.discard(skip * 2 * k);
  boost::random::uniform_01<double> unit;
  DesignRows a(n, std::vector<double>(k)), b = a;
  for (std::size_t j = 0; j < n; ++j) {
    for (std::size_t i = 0; i < k; ++i) a[j][i] = scale(factors[i], unit(engine));
    for (std::size_t i = 0; i < k; ++i) b[j][i] = scale(factors[i], unit(engine));
  }
  DesignRows rows;
  rows.reserve(n * (k + 2));
  rows.insert(rows.end(), a.begin(), a.end());
  rows.insert(rows.end(), b.begin(), b.end());
  for (std::size_t i = 0; i < k; ++i) {
    for (std::size_t j = 0; j < n; ++j) {
      rows.push_back(a[j]);
      rows.back()[i] = b[j][i];
    }
  }
  return rows;
}

SobolIndices sobol_indices(std::span<const double> y, std::size_t n, std::size_t k,
                           std::size_t use_n, int bootstrap, std::uint64_t seed) {
  if (y.size() != n * (k + 2) || use_n < 2 || use_n > n) {
    throw std::invalid_argument("sobol_indices: y must hold n (k + 2) outputs, 2 <= use_n <= n");
  }
  std::vector<std::size_t> idx(use_n);
  std::iota(idx.begin(), idx.end(), 0);
  SobolIndices r;
  estimate(y, n, k, idx, r.first, r.total, r.variance);
  std::mt19937_64 random(seed);
  std::uniform_int_distribution<std::size_t> pick(0, use_n - 1);
  std::vector<std::vector<double>> s(k), t(k);
  std::vector<double> first, total;
  double variance = 0.0;
  for (int b = 0; b < bootstrap; ++b) {
    for (auto& j : idx) j = pick(random);
    estimate(y, n, k, idx, first, total, variance);
    for (std::size_t i = 0; i < k; ++i) {
      s[i].push_back(first[i]);
      t[i].push_back(total[i]);
    }
  }
  for (std::size_t i = 0; i < k; ++i) {
    const bool have = bootstrap > 1;
    r.first_low.push_back(have ? percentile(s[i], 0.025) : r.first[i]);
    r.first_high.push_back(have ? percentile(s[i], 0.975) : r.first[i]);
    r.total_low.push_back(have ? percentile(t[i], 0.025) : r.total[i]);
    r.total_high.push_back(have ? percentile(t[i], 0.975) : r.total[i]);
  }
  return r;
}

MorrisDesign morris_design(const std::vector<Factor>& factors, std::size_t r, std::uint64_t seed) {
  constexpr int kLevels = 4;
  const double step = kLevels / (2.0 * (kLevels - 1));  // 2/3: every move stays on the grid
  const std::size_t k = factors.size();
  std::mt19937_64 random(seed);
  std::uniform_int_distribution<int> start_level(0, kLevels / 2 - 1);
  std::bernoulli_distribution coin(0.5);
  MorrisDesign d;
  d.trajectories = r;
  for (std::size_t t = 0; t < r; ++t) {
    std::vector<double> u(k);
    for (auto& x : u) x = start_level(random) / static_cast<double>(kLevels - 1);
    // Start low or high at random so moves go both ways.
    for (auto& x : u)
      if (coin(random)) x += step;
    std::vector<std::size_t> order(k);
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), random);
    const auto to_row = [&] {
      std::vector<double> row(k);
      for (std::size_t i = 0; i < k; ++i) row[i] = scale(factors[i], u[i]);
      return row;
    };
    d.rows.push_back(to_row());
    for (std::size_t i : order) {
      const double delta = u[i] + step <= 1.0 + 1e-12 ? step : -step;
      u[i] += delta;
      d.moved.push_back(i);
      d.delta.push_back(delta);
      d.rows.push_back(to_row());
    }
  }
  return d;
}

MorrisIndices morris_indices(const MorrisDesign& d, std::size_t k, std::span<const double> y) {
  if (y.size() != d.rows.size()) throw std::invalid_argument("morris_indices: one output per row");
  std::vector<std::vector<double>> effects(k);
  for (std::size_t t = 0; t < d.trajectories; ++t) {
    for (std::size_t s = 0; s < k; ++s) {
      const std::size_t row = t * (k + 1) + s;
      const std::size_t step = t * k + s;
      effects[d.moved[step]].push_back((y[row + 1] - y[row]) / d.delta[step]);
    }
  }
  MorrisIndices m;
  for (const auto& e : effects) {
    const double n = static_cast<double>(e.size());
    const double mu = std::accumulate(e.begin(), e.end(), 0.0) / n;
    double abs_sum = 0.0, sq = 0.0;
    for (double x : e) {
      abs_sum += std::abs(x);
      sq += (x - mu) * (x - mu);
    }
    m.mu.push_back(mu);
    m.mu_star.push_back(abs_sum / n);
    m.sigma.push_back(n > 1 ? std::sqrt(sq / (n - 1)) : 0.0);
  }
  return m;
}

}  // namespace piezo::model
