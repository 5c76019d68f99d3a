#pragma once
// The one error type for bad input: it names the file (or "--set"), the key
// and what is allowed, and the CLI turns it into exit code 2.

#include <stdexcept>
#include <string>

namespace piezo::config {

class ConfigError : public std::runtime_error {
 public:
  ConfigError(const std::string& source, const std::string& key, const std::string& message)
      : std::runtime_error(source + ": " + key + ": " + message), source_(source), key_(key) {}

  [[nodiscard]] const std::string& source() const { return source_; }
  [[nodiscard]] const std::string& key() const { return key_; }

 private:
  std::string source_;
  std::string key_;
};

}  // namespace piezo::config
