#pragma once
/// @file
/// A whole file's bytes, the one way the tree reads a small file (configs,
/// calibrations, a run's config, the view's assets): nullopt when it
/// cannot be opened, so each caller says in its own words what is missing.

#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>

namespace piezo {

[[nodiscard]] inline std::optional<std::string> read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream text;
  text << in.rdbuf();
  return std::move(text).str();
}

}  // namespace piezo
