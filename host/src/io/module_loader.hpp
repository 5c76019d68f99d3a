#pragma once
// Loads one of piezo's modules (a shared library with a heavy dependency,
// e.g. libpiezo_h5.so with HDF5) the first time a program needs it, and
// finds its entry point. A module lives in the install's module folder
// (lib/<triplet>/piezo beside bin/); in the build tree it is looked for
// where the build put it.

#include <string>

namespace piezo::host {

/// How a module's symbols are shared.
enum class ModuleScope {
  own,     ///< kept to the module (RTLD_LOCAL)
  global,  ///< offered to what loads later (RTLD_GLOBAL): Open MPI's own
           ///< plugins resolve their symbols in libmpi
};

/// The address of `entry` (an extern "C" function) in module `file` (e.g.
/// "libpiezo_h5.so"), loaded on the first call. Throws std::runtime_error
/// naming the places looked in and the loader's reason.
[[nodiscard]] void* module_entry(const std::string& file, const char* entry,
                                 ModuleScope scope = ModuleScope::own);

}  // namespace piezo::host
