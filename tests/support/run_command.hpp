#pragma once
// Runs a shell command and captures its exit code, stdout and stderr: the
// CLI tests drive the real `piezo` binary exactly as a person or script would.

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

namespace piezo::testing {

struct CommandResult {
  int exit_code;
  std::string out;
  std::string err;
};

/// The directories fresh_temp_dir made, removed when the test program
/// ends (by the process that made them, not by a forked child), unless
/// PIEZO_KEEP_TEST_DIRS is set to look at them after a failure.
class TempDirs {
 public:
  TempDirs() = default;
  TempDirs(const TempDirs&) = delete;
  TempDirs& operator=(const TempDirs&) = delete;
  ~TempDirs() {
    if (::getpid() != owner_ || std::getenv("PIEZO_KEEP_TEST_DIRS") != nullptr) return;
    std::error_code ignored;
    for (const auto& dir : dirs_) std::filesystem::remove_all(dir, ignored);
  }
  void add(const std::filesystem::path& dir) { dirs_.push_back(dir); }

 private:
  pid_t owner_ = ::getpid();
  std::vector<std::filesystem::path> dirs_;
};

inline TempDirs& temp_dirs() {
  static TempDirs dirs;
  return dirs;
}

inline std::filesystem::path fresh_temp_dir(std::string tag) {
  // A parameterised test's name holds a '/': one directory, not two.
  std::replace(tag.begin(), tag.end(), '/', '-');
  const auto dir = std::filesystem::temp_directory_path() /
                   ("piezo-test-" + tag + "-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  temp_dirs().add(dir);
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

inline std::string read_all(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace piezo::testing
