#include "module_loader.hpp"

#include <dlfcn.h>
#include <fmt/format.h>

#include <filesystem>
#include <stdexcept>
#include <vector>

namespace piezo::host {

void* module_entry(const std::string& file, const char* entry, ModuleScope scope) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  // Installed: the module folder relative to bin/; built: where CMake put it.
  std::vector<fs::path> places;
  if (!ec) places.push_back(exe.parent_path() / PIEZO_MODULE_DIR_FROM_BIN / file);
  places.push_back(fs::path(PIEZO_MODULE_BUILD_DIR) / file);
  std::string reasons;
  for (const fs::path& place : places) {
    // RTLD_NOW: a module that cannot resolve says so here, not at a first call.
    void* handle =
        dlopen(place.c_str(), RTLD_NOW | (scope == ModuleScope::global ? RTLD_GLOBAL : RTLD_LOCAL));
    if (handle == nullptr) {
      reasons += fmt::format("; {}", dlerror());
      continue;
    }
    if (void* symbol = dlsym(handle, entry); symbol != nullptr) return symbol;
    reasons += fmt::format("; {}: no {}", place.string(), entry);
  }
  throw std::runtime_error(fmt::format("cannot load the module {}{}", file, reasons));
}

}  // namespace piezo::host
