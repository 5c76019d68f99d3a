#include "gnuplot.hpp"

#include <sys/wait.h>

#include <cstdio>
#include <stdexcept>

namespace piezo::host {

std::string gnuplot_quote(const std::string& path) {
  std::string out = "'";
  for (char c : path) {
    if (c == '\'')
      out += "''";
    else
      out += c;
  }
  return out + "'";
}

void run_gnuplot(const std::string& script) {
  FILE* pipe = popen("gnuplot", "w");
  if (pipe == nullptr) throw std::runtime_error("cannot start gnuplot");
  // noenhanced: column names such as theta_dot are text, not subscripts.
  std::fputs("set datafile separator ','\nset termoption noenhanced\n", pipe);
  std::fputs(script.c_str(), pipe);
  const int status = pclose(pipe);
  if (status == -1 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw std::runtime_error("gnuplot failed (exit status " + std::to_string(status) +
                             "); is gnuplot installed?");
  }
}

}  // namespace piezo::host
