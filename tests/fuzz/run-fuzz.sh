#!/usr/bin/env bash
# One fuzz test (CTest label "fuzz"): builds a libFuzzer target with clang
# (address + undefined sanitizers) from the sources it tests and runs it
# for a bounded time on the seed corpus kept in the repository
# (corpus/TARGET). Crashes are written to WORK_DIR; once fixed, keep them in
# the corpus as regression inputs.
# Exits 77 (CTest: skipped) when clang or its libFuzzer runtime is missing.
# Usage: run-fuzz.sh SOURCE_DIR WORK_DIR SECONDS TARGET
#   TARGET: protocol (frames and messages), config (TOML and --set),
#           modbus (register decoding, responses from a loopback peer),
#           logs (journal, CSV and HDF5 readers)
set -euo pipefail
src="$1"
work="$2/$4"
seconds="$3"
target="$4"
command -v clang++ >/dev/null || { echo "SKIP: clang++ not installed (Debian: clang)"; exit 77; }
mkdir -p "$work/corpus"
if ! echo 'extern "C" int LLVMFuzzerTestOneInput(const unsigned char*, unsigned long) { return 0; }' |
    clang++ -x c++ -fsanitize=fuzzer - -o "$work/probe" 2>/dev/null; then
  echo "SKIP: clang's libFuzzer runtime missing (Debian: libclang-rt-14-dev)"
  exit 77
fi
# The name tables (model/include/piezo) are the bottom of the tree: every layer's headers use them.
hal_includes=(-I"$src/hal/include" -I"$src/model/include")
for d in "$src"/hal/*/include; do hal_includes+=(-I"$d"); done
linked=()  # sources only linked, built plain (below)
case "$target" in
  protocol)
    sources=("$src"/firmware/protocol/src/{frame,message,messages}.cpp)
    flags=(-I"$src/firmware/protocol/include" -I"$src/firmware/include" -I"$src/model/include"
           "${hal_includes[@]}")
    libs=(-lfmt) ;;
  config)
    sources=("$src"/hal/config/src/section_reader.cpp
             "$src"/firmware/config/{model_config,config_file,board_sections,host_sections,rig_sim_sections}.cpp
             "$src"/firmware/src/{request_limits,request_arguments,move_request}.cpp
             "$src"/hal/{sim,modbus,gpiod,comedi}/src/*_backends.cpp
             "$src"/hal/registry/src/backends.cpp
             "$src"/hal/modbus/src/register_map.cpp "$src"/model/src/{parameters,waveform}.cpp)
    # The backends read their own sections, so the registry links every
    # backend's device (and the simulated rig, the model behind it): only
    # linked, never reached from a config, so built plain (no sanitizers,
    # no coverage) and in parallel.
    for f in "$src"/hal/{sim,modbus,gpio,gpiod,posix,comedi}/src/*.cpp "$src"/model/src/*.cpp \
             "$src"/model/src/hybrid/*.cpp; do
      [[ " ${sources[*]} " == *" $f "* || $f == */global_sensitivity.cpp ]] || linked+=("$f")
    done
    flags=(-I"$src/firmware" -I"$src/hal/config/include"
           -I"$src/firmware/include" "${hal_includes[@]}"
           -I"$src/model/include" -I/usr/include/eigen3 $(pkg-config --cflags libmodbus libgpiod comedilib))
    libs=(-lfmt $(pkg-config --libs libmodbus libgpiod comedilib) -lpthread) ;;
  modbus)
    sources=("$src"/hal/modbus/src/{link,modbus_sensor,register_map}.cpp
             "$src"/hal/posix/src/monotonic_clock.cpp)
    flags=("${hal_includes[@]}" $(pkg-config --cflags libmodbus))
    libs=($(pkg-config --libs libmodbus) -lfmt) ;;
  logs)
    # HDF5 linked in (hdf5_store.cpp): the module loader is never reached.
    sources=("$src"/host/src/io/{fit_io,h5_file,hdf5_store,module_loader,run_journal,run_recovery,catalogue,parameters_json}.cpp
             "$src"/model/src/{parameters,waveform,simulate_names}.cpp)
    flags=(-I"$src/host/src" -I"$src/firmware" -I"$src/hal/config/include" -I"$src/model/include"
           -I/usr/include/eigen3 $(pkg-config --cflags hdf5)
           -DPIEZO_MODULE_DIR_FROM_BIN='"."' -DPIEZO_MODULE_BUILD_DIR='"."')
    libs=($(pkg-config --libs hdf5) -lz -lfmt -ldl) ;;
  *) echo "unknown fuzz target $target"; exit 2 ;;
esac
# Each file compiles on its own, both cores at once, through the compiler
# cache where there is one (cmake/ccache.cmake says why base_dir and
# hash_dir): a clone that changed nothing of a target links what an earlier
# clone compiled. compile DIR FLAGS... -- FILES...: one object a file in
# DIR, named by the file's path under the source tree.
compiler=(clang++)
if command -v ccache >/dev/null; then
  export CCACHE_BASEDIR="$src" CCACHE_NOHASHDIR=1 CCACHE_MAXSIZE=2G
  compiler=(ccache clang++)
fi
export SRC="$src"
object_of() {  # DIR FILE: FILE's object in DIR, named by its path under the source tree
  local rel="${2#"$SRC"/}"
  echo "$1/${rel//\//_}.o"
}
export -f object_of
objects=()
compile() {
  local dir="$1" f flags=()
  shift
  while [ "$1" != -- ]; do flags+=("$1"); shift; done
  shift
  mkdir -p "$dir"
  for f in "$@"; do objects+=("$(object_of "$dir" "$f")"); done
  printf '%s\0' "$@" | DIR="$dir" xargs -0 -P "$(nproc)" -I{} bash -c \
    'exec "$@" -c "$0" -o "$(object_of "$DIR" "$0")"' {} "${compiler[@]}" "${flags[@]}"
}
# TOML_ASSERT: as in the project's builds (CMakeLists.txt says why).
if ((${#linked[@]})); then compile "$work/linked" -std=c++20 -O0 -w "${flags[@]}" -- "${linked[@]}"; fi
fuzzed=(-fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined)
# The fuzzer's own file takes libFuzzer's entry point; the files it tests
# only its instrumentation (-fsanitize=fuzzer-no-link).
compile "$work/fuzzed" -std=c++20 -O1 -g "${fuzzed[@]/fuzzer,/fuzzer-no-link,}" \
  -ffile-prefix-map="$src/"= -D'TOML_ASSERT(expr)=((void)0)' "${flags[@]}" \
  -- "$src/tests/fuzz/${target}_fuzz.cpp" "${sources[@]}"
clang++ "${fuzzed[@]}" "${objects[@]}" "${libs[@]}" -o "$work/${target}_fuzz"
# New inputs go to the work corpus; the repository's seeds are read only.
# A crash exits 1: libFuzzer's own default, 77, is CTest's "skipped".
"$work/${target}_fuzz" -max_total_time="$seconds" -max_len=70000 -timeout=10 \
  -error_exitcode=1 -timeout_exitcode=1 \
  -artifact_prefix="$work/" "$work/corpus" "$src/tests/fuzz/corpus/$target"
