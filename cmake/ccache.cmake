# The compiler cache, when the machine has one (scripts/setup.sh installs
# ccache; nothing needs it). The test command builds the same sources four
# times a run and CI builds each run in a fresh clone, so most compilations
# were done before, in another folder.
#
# - base_dir: paths under the source tree reach the hash relative to the
#   build directory, so a clone in another folder hits what an earlier
#   clone filled; the unity sources CMake writes include their files by
#   absolute path, which ccache rewrites the same way.
# - hash_dir off: with -g ccache would hash the working directory; the
#   objects' debug info names the source tree relative to it instead
#   (-ffile-prefix-map), so a cached object is right for any clone.
# - The sanitizer, cross and optimised builds differ in their flags and
#   compilers, which ccache hashes: each has its own entries.
# - max_size bounds the cache (docs/testing.md has what the four builds
#   take).
find_program(PIEZO_CCACHE ccache)
if(PIEZO_CCACHE AND NOT DEFINED CMAKE_CXX_COMPILER_LAUNCHER)
  set(launcher ${CMAKE_COMMAND} -E env
    CCACHE_BASEDIR=${PROJECT_SOURCE_DIR}
    CCACHE_NOHASHDIR=1
    CCACHE_MAXSIZE=2G
    ${PIEZO_CCACHE})
  set(CMAKE_C_COMPILER_LAUNCHER ${launcher})
  set(CMAKE_CXX_COMPILER_LAUNCHER ${launcher})
  add_compile_options(-ffile-prefix-map=${PROJECT_SOURCE_DIR}/=)
  message(STATUS "Compiler cache: ${PIEZO_CCACHE}")
endif()
