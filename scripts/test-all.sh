#!/usr/bin/env bash
# Quick start, second command: set up, then build and run the whole test
# suite in the optimised build (warnings as errors) and under
# AddressSanitizer + UndefinedBehaviorSanitizer, and the threaded suites
# under ThreadSanitizer.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh ci --gpio-sim
ctest --preset ci -j "$(nproc)"
cmake --preset asan >/dev/null
cmake --build --preset asan -j "$(nproc)"
ctest --preset asan -j "$(nproc)"
# The thread sanitizer on the suites whose code runs on several threads
# in-process (rings, clocks, loops, whole runs with the observer); the full
# tsan build passes the rest too, but costs CI minutes.
cmake --preset tsan >/dev/null
cmake --build --preset tsan -j "$(nproc)" --target firmware_tests hal_tests hil_tests
ctest --preset tsan -j "$(nproc)" -L "firmware_tests|hal_tests|hil_tests"
