#!/usr/bin/env bash
# Quick start, second command: set up, then build and run the whole test
# suite in the optimised build (warnings as errors, with the deploy tests:
# packages, systemd notify, the netns link cut, the arm64 piezod under
# qemu-aarch64 against the native host), the board build's own tests under
# qemu-aarch64, the whole suite under AddressSanitizer +
# UndefinedBehaviorSanitizer, and the threaded suites under ThreadSanitizer.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh ci --gpio-sim --arm64
ctest --preset ci -j "$(nproc)"
# The board build's tests run under the emulator: the command line shows it.
ctest --test-dir build/arm64 -R piezod_version -V | grep -E "Test command|^[0-9]+: piezod"
ctest --preset arm64 -j "$(nproc)"
cmake --preset asan >/dev/null
cmake --build --preset asan -j "$(nproc)"
ctest --preset asan -j "$(nproc)"
# The thread sanitizer on the suites whose code runs on several threads
# in-process (rings, clocks, loops, whole runs with the observer); the full
# tsan build passes the rest too, but costs CI minutes.
cmake --preset tsan >/dev/null
cmake --build --preset tsan -j "$(nproc)" --target firmware_tests hal_tests hil_tests
ctest --preset tsan -j "$(nproc)" -L "firmware_tests|hal_tests|hil_tests"
