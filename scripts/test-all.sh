#!/usr/bin/env bash
# Quick start, second command: set up, then build and run the whole test
# suite in the optimised build (warnings as errors, with the deploy tests:
# packages, systemd notify, the netns link cut, the arm64 piezod under
# qemu-aarch64 against the native host), the board build's own tests under
# qemu-aarch64, the suite under AddressSanitizer + UndefinedBehaviorSanitizer
# (all but the kill test and the soak, which the optimised leg runs), and the
# threaded suites under ThreadSanitizer.
#
# Every leg runs even when an earlier one failed, so one failing test does
# not hide whether the others pass; the exit status is non-zero when any leg
# failed, and the last lines name them. After each leg no process that its
# tests started may be left running.
set -euo pipefail
cd "$(dirname "$0")/.."

# Each leg says when it starts, so a slow leg shows in the log.
phase() { printf '\n== %s (at %dm%02ds)\n' "$1" $((SECONDS / 60)) $((SECONDS % 60)); }

# Every process a leg starts inherits this mark in its environment (CTest,
# the tests, the helpers they spawn, the browser); one still alive after its
# leg has outlived the test that started it.
export PIEZO_TEST_MARK="piezo-test-$$-$RANDOM"
leftovers() {
  local env pid found=()
  for env in /proc/[0-9]*/environ; do
    pid=${env#/proc/}
    pid=${pid%/environ}
    [ "$pid" = "$$" ] && continue
    grep -qzx "PIEZO_TEST_MARK=$PIEZO_TEST_MARK" "$env" 2>/dev/null && found+=("$pid")
  done
  ((${#found[@]})) || return 0
  echo "processes left behind by the tests:"
  for pid in "${found[@]}"; do
    printf '  %s: %s\n' "$pid" "$(tr '\0' ' ' < "/proc/$pid/cmdline" 2>/dev/null)"
  done
  kill -KILL "${found[@]}" 2>/dev/null || true
  return 1
}

# The compiler cache's hits and misses so far ("hits misses"; "- -"
# without ccache): a leg's share is the difference across it.
cache_counts() {
  command -v ccache > /dev/null || { echo "- -"; return; }
  ccache --print-stats | awk -F'\t' '
    $1 == "direct_cache_hit" || $1 == "preprocessed_cache_hit" { hits += $2 }
    $1 == "cache_miss" { misses = $2 }
    END { print hits + 0, misses + 0 }'
}

failed=()
table=()
# leg NAME MINUTES FUNCTION [tests]: runs the function with errexit in
# force, in a shell of its own that is stopped after MINUTES (a hung test
# or build costs its leg, not the run); after a leg of tests, looks for
# leftovers (the set-up's package scripts may start services of their
# own). Each leg's time, result and compiler-cache figures go to the table
# printed at the end.
leg() {
  local name=$1 minutes=$2 function=$3 rc=0 start=$SECONDS before after result cache
  phase "$name"
  read -r -a before <<< "$(cache_counts)"
  timeout --kill-after=30 $((minutes * 60)) bash -c "set -euo pipefail; $function" &
  wait $! || rc=$?
  if [ "${4:-}" = tests ]; then leftovers || rc=$?; fi
  read -r -a after <<< "$(cache_counts)"
  result=passed
  if ((rc == 124)); then
    result="FAILED (over its $minutes min)"
  elif ((rc)); then
    result="FAILED (exit $rc)"
  fi
  if ((rc)); then
    failed+=("$name")
    echo "== $name: $result"
  fi
  cache="-"
  if [ "${before[0]}" != - ]; then
    local hits=$((after[0] - before[0])) misses=$((after[1] - before[1]))
    cache="$hits / $misses"
    ((hits + misses)) && cache+=" ($((100 * hits / (hits + misses))) % hits)"
  fi
  table+=("$(printf '%-46s %3dm%02ds  %-26s %s' "$name" $(((SECONDS - start) / 60)) \
    $(((SECONDS - start) % 60)) "$result" "$cache")")
}

set_up() { scripts/setup.sh ci --gpio-sim --arm64; }

whole_suite() { ctest --preset ci -j "$(nproc)"; }

board_build() {
  # The board build's tests run under the emulator: the command line shows it.
  ctest --test-dir build/arm64 -R piezod_version -V | grep -E "Test command|^[0-9]+: piezod"
  ctest --preset arm64 -j "$(nproc)"
}

address_sanitizer() {
  cmake --preset asan >/dev/null
  cmake --build --preset asan -j "$(nproc)"
  # Without the kill test and the soak (docs/testing.md says why).
  ctest --preset asan -j "$(nproc)"
}

# The thread sanitizer on the suites whose code runs on several threads
# in-process (rings, clocks, loops, whole runs with the observer, the view's
# server with its event loop and workers); the full tsan build passes the
# rest too, but costs CI minutes.
thread_sanitizer() {
  cmake --preset tsan >/dev/null
  cmake --build --preset tsan -j "$(nproc)" --target firmware_tests hal_tests sim_run_tests view_tests
  ctest --preset tsan -j "$(nproc)" -L "firmware_tests|hal_tests|sim_run_tests|view" \
    -E "^view_(browser|rig|load|wide_bind)$"
}

export -f set_up whole_suite board_build address_sanitizer thread_sanitizer
# Each leg's bound is about twice its time on a machine that has built the
# tree once, and above its time from nothing (docs/testing.md has both).
leg "set-up and the optimised build" 30 set_up
leg "the whole suite" 25 whole_suite tests
leg "the board build under qemu-aarch64" 8 board_build tests
leg "AddressSanitizer + UndefinedBehaviorSanitizer" 25 address_sanitizer tests
leg "ThreadSanitizer" 10 thread_sanitizer tests
phase "done"
printf '\n%-46s %8s  %-26s %s\n' "leg" "time" "result" "compiler cache: hits / misses"
printf '%s\n' "${table[@]}"
printf '%-46s %3dm%02ds\n' "all legs" $((SECONDS / 60)) $((SECONDS % 60))
if ((${#failed[@]})); then
  echo "failed legs:"
  printf '  %s\n' "${failed[@]}"
  exit 1
fi
echo "all legs passed"
