#pragma once
// A board's silence, on its own: `piezo` reports it (main.cpp) without
// linking the board client, which lives in the rig commands' module.

#include <stdexcept>

namespace piezo::host {

/// No reply within the timeout: the link or the daemon is down.
class LinkTimeout : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace piezo::host
