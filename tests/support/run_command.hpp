#pragma once
// Runs a shell command and captures its exit code, stdout and stderr: the
// CLI tests drive the real `piezo` binary exactly as a person or script would.

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace piezo::testing {

struct CommandResult {
  int exit_code;
  std::string out;
  std::string err;
};

inline std::filesystem::path fresh_temp_dir(const std::string& tag) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("piezo-test-" + tag + "-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

inline CommandResult run_command(const std::string& command) {
  const auto err_path =
      std::filesystem::temp_directory_path() / ("piezo-test-stderr-" + std::to_string(::getpid()));
  FILE* pipe = popen((command + " 2>" + err_path.string()).c_str(), "r");
  CommandResult result{-1, {}, {}};
  if (pipe == nullptr) return result;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), pipe)) > 0) result.out.append(buf.data(), n);
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  std::ifstream err(err_path);
  std::stringstream ss;
  ss << err.rdbuf();
  result.err = ss.str();
  std::filesystem::remove(err_path);
  return result;
}

inline void write_file(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path) << text;
}

}  // namespace piezo::testing
