// Where the tests find the programs they run and the source tree they read.
//
// Defined in build_paths.cpp, which CMake writes into the build tree: these
// paths name this clone's folders, and on the tests' compile lines they
// would keep the compiler cache from serving any test file to another
// clone. Here only one small file per build differs.
#pragma once

namespace build_paths {
extern const char source_dir[];  ///< the source tree (configs, docs, scripts)
extern const char piezo[];       ///< the `piezo` binary; empty where the host is not built
extern const char piezod[];      ///< the `piezod` binary
}  // namespace build_paths
