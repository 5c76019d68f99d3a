#!/usr/bin/env bash
# The protocol fuzz test (CTest label "fuzz"): builds the libFuzzer target
# with clang (address + undefined sanitizers) from the protocol sources and
# runs it for a bounded time on the seed corpus kept in the repository.
# Crashes are written to WORK_DIR; keep them in the corpus once fixed.
# Exits 77 (CTest: skipped) when clang or its libFuzzer runtime is missing.
# Usage: run-fuzz.sh SOURCE_DIR WORK_DIR SECONDS
set -euo pipefail
src="$1"
work="$2"
seconds="$3"
command -v clang++ >/dev/null || { echo "SKIP: clang++ not installed (Debian: clang)"; exit 77; }
mkdir -p "$work/corpus"
if ! echo 'extern "C" int LLVMFuzzerTestOneInput(const unsigned char*, unsigned long) { return 0; }' |
    clang++ -x c++ -fsanitize=fuzzer - -o "$work/probe" 2>/dev/null; then
  echo "SKIP: clang's libFuzzer runtime missing (Debian: libclang-rt-14-dev)"
  exit 77
fi
clang++ -std=c++20 -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined \
  -I"$src/firmware/protocol/include" -I"$src/firmware/include" -I"$src/hal/include" \
  "$src/tests/fuzz/protocol_fuzz.cpp" "$src/firmware/protocol/src/frame.cpp" \
  "$src/firmware/protocol/src/message.cpp" -lfmt -o "$work/protocol_fuzz"
# New inputs go to the work corpus; the repository's seeds are read only.
"$work/protocol_fuzz" -max_total_time="$seconds" -max_len=70000 -timeout=10 \
  -artifact_prefix="$work/" "$work/corpus" "$src/tests/fuzz/corpus/protocol"
