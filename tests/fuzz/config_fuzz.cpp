// libFuzzer target: the rig and model configs as a user writes them -- a
// TOML file and `--set key=value` overrides. The input is the file, then
// optionally a line "--set" and one override per line. A refusal
// (ConfigError, naming the key and the file) is the expected answer to bad
// input; any other exception, a crash or a sanitizer report is a bug.
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "piezo/config/config_error.hpp"
#include "config/config_file.hpp"

namespace {

const std::string& scratch_file() {
  static const std::string path = "/tmp/piezo-config-fuzz-" + std::to_string(::getpid()) + ".toml";
  return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  const std::size_t split = input.find("\n--set\n");
  std::vector<std::string> sets;
  if (split != std::string::npos) {
    std::istringstream lines(input.substr(split + 7));
    for (std::string line; std::getline(lines, line);) sets.push_back(line);
  }
  std::ofstream(scratch_file(), std::ios::binary | std::ios::trunc)
      << input.substr(0, std::min(split, input.size()));
  using piezo::config::ConfigError;
  using piezo::config::ConfigScope;
  for (const ConfigScope scope : {ConfigScope::whole, ConfigScope::sensor}) {
    try {
      (void)piezo::config::load_config_file(scratch_file(), sets, scope);
    } catch (const ConfigError&) {
    }
  }
  try {
    (void)piezo::config::load_model_config(scratch_file());
  } catch (const ConfigError&) {
  }
  return 0;
}
