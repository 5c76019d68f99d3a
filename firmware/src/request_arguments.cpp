#include "piezo/firmware/request_arguments.hpp"

#include <cstdio>
#include <limits>

namespace piezo::firmware {

std::string allowed_text(const Argument& a) {
  if (!a.choices.empty()) {
    std::string out;
    std::string_view rest = a.choices;
    while (!rest.empty()) {
      const auto comma = rest.find(", ");
      out += (out.empty() ? "`" : ", `") + std::string(rest.substr(0, comma)) + "`";
      rest = comma == std::string_view::npos ? std::string_view() : rest.substr(comma + 2);
    }
    return out;
  }
  char low[32];
  std::snprintf(low, sizeof low, "%g", a.allowed.min);
  if (a.limit.empty() && a.allowed.max == std::numeric_limits<double>::infinity()) {
    return std::string(a.allowed.min_open ? "> " : "≥ ") + low;  // a count from min up
  }
  if (a.limit.empty()) return a.allowed.text();
  return std::string(a.allowed.min_open ? "(" : "[") + low + ", " + std::string(a.limit) +
         (a.allowed.max_open ? ")" : "]");
}

}  // namespace piezo::firmware
