#pragma once
// Plots are drawn by gnuplot (Debian's gnuplot-nox, pngcairo terminal): the
// caller writes its data as CSV and hands over a script.

#include <string>

namespace piezo::host {

/// Runs gnuplot on `script` (with "set datafile separator ','" prepended).
/// Throws with gnuplot's exit status when it fails or is missing.
void run_gnuplot(const std::string& script);

/// Quotes a path for use inside a gnuplot script.
[[nodiscard]] std::string gnuplot_quote(const std::string& path);

}  // namespace piezo::host
