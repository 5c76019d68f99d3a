#include "global_sensitivity_study.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "io/columns.hpp"
#include "io/gnuplot.hpp"
#include "jobs/interruption.hpp"
#include "config/model_config.hpp"
#include "mpi_ranks.hpp"
#include "jobs/parallel.hpp"
#include "piezo/config/config_error.hpp"
#include "piezo/model/frequency_sweep.hpp"
#include "piezo/model/global_sensitivity.hpp"
#include "piezo/model/sensitivity.hpp"
#include "jobs/progress.hpp"

namespace piezo::host {
namespace {

using json = nlohmann::json;

std::vector<model::Factor> factors(const model::Parameters& base, const GlobalStudyOptions& o) {
  std::vector<std::string> names = o.params;
  if (names.empty()) {
    for (const auto& spec : model::parameter_specs()) names.emplace_back(spec.name);
  }
  std::vector<model::Factor> out;
  for (const auto& name : names) {
    double value = 0.0;
    if (name == "D") {
      value = base.drive.D();
    } else if (const auto* spec = model::find_parameter(name)) {
      model::Parameters p = base;
      value = spec->ref(p);
    } else {
      throw config::ConfigError(o.names.params, name,
                                "allowed: Table 1 symbols (V0, f, mu, ...) or D");
    }
    const double half = std::abs(value) * o.range_pct / 100.0;
    double low = value - half, high = value + half;
    // A range that leaves the parameter's own domain is cut to it (e.g.
    // C_dr, a duty ratio, stops at 1); the JSON shows the range used.
    if (const auto* spec = model::find_parameter(name)) {
      low = std::max(low, spec->min);
      high = std::min(high, spec->max);
    }
    out.push_back({name, low, high});
  }
  return out;
}

model::Parameters at(const model::Parameters& base, const std::vector<model::Factor>& f,
                     const std::vector<double>& row) {
  model::Parameters p = base;
  for (std::size_t i = 0; i < f.size(); ++i) p = model::with_level(p, f[i].name, row[i]);
  return p;
}

double output(const model::Parameters& p, const GlobalStudyOptions& o) {
  if (o.output == "velocity") return model::mean_velocity(p, o.model, o.runtime_s, interruptible());
  const int periods = std::max(3, static_cast<int>(std::lround(o.runtime_s * p.drive.f)));
  const auto m = model::period_metrics(p, o.model, {periods, 1, 100}, interruptible());
  return o.output == "step" ? m.step_rad : m.backslip_rad;
}

std::vector<double> evaluate(const model::Parameters& base, const std::vector<model::Factor>& f,
                             const model::DesignRows& rows, const GlobalStudyOptions& o) {
  for (const auto& row : rows) {  // every row checked before any is simulated
    config::require_valid(at(base, f, row), o.names.range);
  }
  // Under MPI each rank takes every size-th row; rank 0 gathers them all.
  const MpiRanks& mpi = MpiRanks::get();
  std::vector<std::size_t> mine;
  for (std::size_t i = static_cast<std::size_t>(mpi.rank()); i < rows.size();
       i += static_cast<std::size_t>(mpi.size())) {
    mine.push_back(i);
  }
  std::vector<double> y(rows.size(), 0.0);
  std::size_t shown = 0;
  parallel_for(
      mine.size(), [&](std::size_t j) { y[mine[j]] = output(at(base, f, rows[mine[j]]), o); },
      [&](std::size_t done, std::size_t total) {
        // A line each 64 runs at most (the reports come with any count).
        if (mpi.root() && (done / 64 != shown / 64 || done == total)) {
          shown = done;
          show_progress(
              fmt::format("\rsensitivity ({}): {}/{} runs done{}{}", o.method, done, total,
                          mpi.size() > 1 ? fmt::format(" on rank 0 of {}", mpi.size()) : "",
                          done == total ? "\n" : ""));
        }
      });
  mpi.gather_to_root(y);
  return y;
}

void write_design(const std::string& dir, const std::vector<model::Factor>& f,
                  const model::DesignRows& rows, const std::vector<double>& y) {
  std::vector<std::vector<double>> cols(f.size());
  for (const auto& r : rows)
    for (std::size_t i = 0; i < f.size(); ++i) cols[i].push_back(r[i]);
  std::vector<Column> c;
  for (std::size_t i = 0; i < f.size(); ++i) c.push_back({f[i].name, cols[i]});
  c.push_back({"y", y});
  write_csv(dir + "/design.csv", c);
}

json sobol(const model::Parameters& base, const GlobalStudyOptions& o) {
  const auto f = factors(base, o);
  const std::size_t n = o.samples;
  const std::size_t k = f.size();
  const auto rows = model::saltelli_design(f, n, o.seed);
  const auto y = evaluate(base, f, rows, o);
  if (!MpiRanks::get().root()) return nullptr;  // rank 0 computes and writes
  const auto s = model::sobol_indices(y, n, k, n, o.bootstrap, o.seed);
  std::vector<std::size_t> order(k);
  for (std::size_t i = 0; i < k; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](auto a, auto b) { return s.total[a] > s.total[b]; });
  if (!o.out.empty()) {
    namespace fs = std::filesystem;
    fs::create_directories(o.out);
    write_design(o.out, f, rows, y);
    std::string table = "name,S1,S1_low,S1_high,ST,ST_low,ST_high\n";
    for (std::size_t i : order) {
      table +=
          fmt::format("{},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g}\n", f[i].name, s.first[i],
                      s.first_low[i], s.first_high[i], s.total[i], s.total_low[i], s.total_high[i]);
    }
    write_text(o.out + "/sobol.csv", table);
    // Convergence: the indices from the first N/16 ... N points of the same design.
    std::string conv = "N";
    for (const auto& factor : f) conv += fmt::format(",S1_{0},ST_{0}", factor.name);
    conv += "\n";
    for (std::size_t m = std::max<std::size_t>(8, n / 16); m <= n; m *= 2) {
      const auto c = model::sobol_indices(y, n, k, m, 0, o.seed);
      conv += std::to_string(m);
      for (std::size_t i = 0; i < k; ++i)
        conv += fmt::format(",{:.6g},{:.6g}", c.first[i], c.total[i]);
      conv += "\n";
    }
    write_text(o.out + "/convergence.csv", conv);
    const std::string csv = gnuplot_quote(o.out + "/sobol.csv");
    run_gnuplot(fmt::format(
        "set terminal pngcairo size 1000,600 noenhanced\nset output {}\nset datafile separator "
        "','\n"
        "set style data histogram\nset style histogram errorbars gap 1 lw 1\nset style fill solid "
        "0.6\n"
        "set key top right\nset grid ytics\nset xtics rotate by -45\nset yrange [-0.05:*]\n"
        "set title 'Sobol indices of the {} ({} %, N = {}, {})'\n"
        "plot {} skip 1 using 2:3:4:xtic(1) title 'first order S1', '' skip 1 using 5:6:7 title "
        "'total ST'\n",
        gnuplot_quote(o.out + "/sobol.png"), o.output, o.range_pct, n,
        o.bootstrap > 1 ? "95 % bootstrap intervals" : "no intervals: bootstrap 0", csv));
    std::string lines;
    for (std::size_t i = 0; i < k; ++i) {
      lines += fmt::format("{}{} skip 1 using 1:{} with linespoints lw 2 title 'ST {}'",
                           i == 0 ? "plot " : ", ", gnuplot_quote(o.out + "/convergence.csv"),
                           3 + 2 * i, f[i].name);
    }
    run_gnuplot(fmt::format(
        "set terminal pngcairo size 1000,600 noenhanced\nset output {}\nset datafile separator "
        "','\n"
        "set logscale x 2\nset grid\nset key outside right\nset xlabel 'N (points of the design "
        "used)'\n"
        "set ylabel 'total index ST'\nset title 'Convergence of the total indices'\n{}\n",
        gnuplot_quote(o.out + "/convergence.png"), lines));
  }
  // Fewer than two resamples give no interval: null, not a zero-width one.
  const bool intervals = o.bootstrap > 1;
  const auto interval = [&](double low, double high) {
    return intervals ? json::array({low, high}) : json();
  };
  json params = json::array();
  for (std::size_t i : order) {
    params.push_back({{"name", f[i].name},
                      {"low", f[i].low},
                      {"high", f[i].high},
                      {"S1", s.first[i]},
                      {"S1_interval", interval(s.first_low[i], s.first_high[i])},
                      {"ST", s.total[i]},
                      {"ST_interval", interval(s.total_low[i], s.total_high[i])}});
  }
  return json{{"method", "sobol"},   {"output", o.output},     {"samples", n},
              {"runs", rows.size()}, {"variance", s.variance}, {"parameters", params}};
}

json morris(const model::Parameters& base, const GlobalStudyOptions& o) {
  const auto f = factors(base, o);
  const std::size_t r = o.samples;
  const auto d = model::morris_design(f, r, o.seed);
  const auto y = evaluate(base, f, d.rows, o);
  if (!MpiRanks::get().root()) return nullptr;
  const auto m = model::morris_indices(d, f.size(), y);
  std::vector<std::size_t> order(f.size());
  for (std::size_t i = 0; i < f.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](auto a, auto b) { return m.mu_star[a] > m.mu_star[b]; });
  if (!o.out.empty()) {
    std::filesystem::create_directories(o.out);
    write_design(o.out, f, d.rows, y);
    std::string table = "name,mu,mu_star,sigma\n";
    for (std::size_t i : order) {
      table +=
          fmt::format("{},{:.6g},{:.6g},{:.6g}\n", f[i].name, m.mu[i], m.mu_star[i], m.sigma[i]);
    }
    write_text(o.out + "/morris.csv", table);
    run_gnuplot(fmt::format(
        "set terminal pngcairo size 900,700 noenhanced\nset output {}\nset datafile separator ','\n"
        "set grid\nunset key\nset xlabel 'mu* (mean |elementary effect|)'\nset ylabel 'sigma'\n"
        "set title 'Morris: influence (mu*) and interaction or nonlinearity (sigma) of the {}'\n"
        "plot {} skip 1 using 3:4 with points pt 7 ps 1.5, '' skip 1 using 3:4:1 with labels "
        "offset 1,1\n",
        gnuplot_quote(o.out + "/morris.png"), o.output, gnuplot_quote(o.out + "/morris.csv")));
  }
  json params = json::array();
  for (std::size_t i : order) {
    params.push_back(
        {{"name", f[i].name}, {"mu", m.mu[i]}, {"mu_star", m.mu_star[i]}, {"sigma", m.sigma[i]}});
  }
  return json{{"method", "morris"},
              {"output", o.output},
              {"trajectories", r},
              {"runs", d.rows.size()},
              {"parameters", params}};
}

void print_table(const json& result) {
  if (result["method"] == "sobol") {
    fmt::print("{:>8} {:>8} {:>19} {:>8} {:>19}\n", "param", "S1", "95 %", "ST", "95 %");
    for (const auto& p : result["parameters"]) {
      fmt::print("{:>8} {:8.4f} [{:8.4f}, {:8.4f}] {:8.4f} [{:8.4f}, {:8.4f}]\n",
                 p["name"].get<std::string>(), p["S1"].get<double>(),
                 p["S1_interval"][0].get<double>(), p["S1_interval"][1].get<double>(),
                 p["ST"].get<double>(), p["ST_interval"][0].get<double>(),
                 p["ST_interval"][1].get<double>());
    }
    return;
  }
  fmt::print("{:>8} {:>12} {:>12} {:>12}\n", "param", "mu*", "mu", "sigma");
  for (const auto& p : result["parameters"]) {
    fmt::print("{:>8} {:12.4g} {:12.4g} {:12.4g}\n", p["name"].get<std::string>(),
               p["mu_star"].get<double>(), p["mu"].get<double>(), p["sigma"].get<double>());
  }
}

}  // namespace

std::size_t default_samples(const std::string& method) {
  return method == "sobol" ? 1024 : 20;
}

json global_study(const model::Parameters& base, const GlobalStudyOptions& o) {
  const auto& n = o.names;
  if (!(o.range_pct > 0.0 && o.range_pct < 100.0)) {
    throw config::ConfigError(n.range, fmt::format("{:g}", o.range_pct), "allowed: (0, 100) %");
  }
  if (std::find(kStudyOutputs.begin(), kStudyOutputs.end(), o.output) == kStudyOutputs.end()) {
    throw config::ConfigError(n.output, o.output,
                              fmt::format("allowed: {}", fmt::join(kStudyOutputs, ", ")));
  }
  if (!(o.runtime_s > 0.0 && o.runtime_s <= 3600.0)) {
    throw config::ConfigError(n.runtime, fmt::format("{:g}", o.runtime_s), "allowed: (0, 3600] s");
  }
  if (o.method == "sobol" && o.samples < 8) {
    throw config::ConfigError(n.samples, std::to_string(o.samples), "allowed: >= 8 for sobol");
  }
  if (o.method == "morris" && o.samples < 2) {
    throw config::ConfigError(n.samples, std::to_string(o.samples),
                              "allowed: >= 2 trajectories for morris (sigma needs two)");
  }
  if (o.method == "sobol" && (o.bootstrap < 0 || o.bootstrap > 100000)) {
    throw config::ConfigError(n.bootstrap, std::to_string(o.bootstrap), "allowed: [0, 100000]");
  }
  for (std::size_t i = 0; i < o.params.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (o.params[i] == o.params[j]) {
        throw config::ConfigError(n.params, o.params[i], "named twice (allowed: each once)");
      }
    }
  }
  return o.method == "sobol" ? sobol(base, o) : morris(base, o);
}

int run_global_study(const model::Parameters& base, const GlobalStudyOptions& o) {
  const json result = global_study(base, o);
  if (result.is_null()) return 0;  // an MPI rank other than 0
  if (o.json) {
    std::cout << result.dump() << "\n";
  } else {
    print_table(result);
  }
  return 0;
}

}  // namespace piezo::host
