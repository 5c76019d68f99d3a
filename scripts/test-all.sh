#!/usr/bin/env bash
# Quick start, second command: set up, then build and run the whole test
# suite in the optimised build (warnings as errors, with the deploy tests:
# packages, systemd notify, the netns link cut, the arm64 piezod under
# qemu-aarch64 against the native host), the board build's own tests under
# qemu-aarch64, the suite under AddressSanitizer + UndefinedBehaviorSanitizer
# (all but the kill test and the soak, which the optimised leg runs), and the
# threaded suites under ThreadSanitizer.
set -euo pipefail
cd "$(dirname "$0")/.."
# Each leg says when it starts, so a slow leg shows in the log.
phase() { printf '\n== %s (at %dm%02ds)\n' "$1" $((SECONDS / 60)) $((SECONDS % 60)); }
phase "set-up and the optimised build"
scripts/setup.sh ci --gpio-sim --arm64
phase "the whole suite"
ctest --preset ci -j "$(nproc)"
phase "the board build under qemu-aarch64"
# The board build's tests run under the emulator: the command line shows it.
ctest --test-dir build/arm64 -R piezod_version -V | grep -E "Test command|^[0-9]+: piezod"
ctest --preset arm64 -j "$(nproc)"
phase "AddressSanitizer + UndefinedBehaviorSanitizer"
cmake --preset asan >/dev/null
cmake --build --preset asan -j "$(nproc)"
phase "the suite under AddressSanitizer (without the kill test and the soak)"
ctest --preset asan -j "$(nproc)"
# The thread sanitizer on the suites whose code runs on several threads
# in-process (rings, clocks, loops, whole runs with the observer, the view's
# server with its event loop and workers); the full tsan build passes the
# rest too, but costs CI minutes.
phase "ThreadSanitizer"
cmake --preset tsan >/dev/null
cmake --build --preset tsan -j "$(nproc)" --target firmware_tests hal_tests sim_run_tests view_tests
ctest --preset tsan -j "$(nproc)" -L "firmware_tests|hal_tests|sim_run_tests|view" \
  -E "^view_(browser|rig|load|wide_bind)$"
phase "done"
