#include "columns.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <memory>
#include <stdexcept>

namespace piezo::host {

void write_csv(const std::string& path, const std::vector<Column>& columns) {
  std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "w"), std::fclose);
  if (!file) throw std::runtime_error("cannot write " + path);
  std::string line;
  for (std::size_t c = 0; c < columns.size(); ++c) line += (c ? "," : "") + columns[c].name;
  fmt::print(file.get(), "{}\n", line);
  const std::size_t rows = columns.empty() ? 0 : columns.front().values.size();
  for (std::size_t r = 0; r < rows; ++r) {
    line.clear();
    for (std::size_t c = 0; c < columns.size(); ++c) {
      if (c) line += ",";
      line += fmt::format("{:.12g}", columns[c].values[r]);
    }
    fmt::print(file.get(), "{}\n", line);
  }
  if (std::ferror(file.get())) throw std::runtime_error("error writing " + path);
}

void write_text(const std::string& path, const std::string& text) {
  std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "w"), std::fclose);
  if (!file) throw std::runtime_error("cannot write " + path);
  if (std::fputs(text.c_str(), file.get()) < 0 || std::fflush(file.get()) != 0) {
    throw std::runtime_error("error writing " + path);
  }
}

}  // namespace piezo::host
