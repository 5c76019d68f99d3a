#pragma once
// Tests that measure real time cannot pass or fail meaningfully under
// software emulation (the arm64 build runs its tests under qemu-aarch64,
// which ctest announces through PIEZO_EMULATOR): they skip, saying why.

#include <gtest/gtest.h>

#include <cstdlib>

#define PIEZO_SKIP_TIMING_UNDER_EMULATION()                                                   \
  if (const char* piezo_emulator = std::getenv("PIEZO_EMULATOR")) {                           \
    GTEST_SKIP() << "measures real time; skipped under emulation (" << piezo_emulator << ")"; \
  }
