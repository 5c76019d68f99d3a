#pragma once
/// @file
/// Every backend the build has, one line each in backends.cpp: a config's
/// `backend` keys choose among them. Each call gives fresh instances at
/// their defaults, for one config to read its sections into.

#include <memory>
#include <vector>

#include "piezo/hal/backend.hpp"

namespace piezo::hal {

[[nodiscard]] std::vector<std::shared_ptr<DriveBackend>> drive_backends();
[[nodiscard]] std::vector<std::shared_ptr<SensorBackend>> sensor_backends();
[[nodiscard]] std::vector<std::shared_ptr<LinesBackend>> lines_backends();

}  // namespace piezo::hal
