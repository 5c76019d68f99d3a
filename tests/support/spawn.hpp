#pragma once
// Starts the `piezo` binary in the background so a test can signal it
// (SIGINT, kill -9) mid-run, as a person at the terminal would.

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <string>
#include <vector>

namespace piezo::testing {

class Spawned {
 public:
  /// Runs argv[0] with its arguments; stdout and stderr go to `log_path`.
  Spawned(const std::vector<std::string>& argv, const std::string& log_path) {
    const pid_t test = getpid();
    pid_ = fork();
    if (pid_ == 0) {
      // Killed by the kernel when the test ends, however it ends (CTest's
      // timeout kills the test, and no destructor runs): no helper outlives
      // its test. The parent may have gone before the call.
      prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (getppid() != test) _exit(127);
      const int fd = open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      dup2(fd, STDOUT_FILENO);
      dup2(fd, STDERR_FILENO);
      std::vector<char*> args;
      for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
      args.push_back(nullptr);
      execv(args[0], args.data());
      _exit(127);
    }
  }
  Spawned(const Spawned&) = delete;
  Spawned& operator=(const Spawned&) = delete;
  ~Spawned() {
    if (pid_ > 0 && !reaped_) {
      kill(pid_, SIGKILL);
      wait_exit();
    }
  }

  void signal(int sig) const { kill(pid_, sig); }
  [[nodiscard]] pid_t pid() const { return pid_; }

  /// The exit code, or 128 + signal number when killed.
  int wait_exit() {
    if (reaped_) return exit_code_;
    int status = 0;
    waitpid(pid_, &status, 0);
    reaped_ = true;
    exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return exit_code_;
  }

  /// True once it has ended (reaped then; wait_exit() gives its code).
  bool exited() {
    if (reaped_) return true;
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) != pid_) return false;
    reaped_ = true;
    exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return true;
  }

 private:
  int exit_code_ = -1;
  pid_t pid_ = -1;
  bool reaped_ = false;
};

}  // namespace piezo::testing
