#include "h5_file.hpp"

#include "module_loader.hpp"

// Defined where hdf5_store.cpp is linked in; otherwise null, and the module
// is loaded.
extern "C" const piezo::host::H5Library* piezo_h5_library() __attribute__((weak));

namespace piezo::host {
namespace {

const H5Library& library() {
  static const H5Library* const loaded = [] {
    if (piezo_h5_library != nullptr) return piezo_h5_library();
    using Entry = const H5Library* (*)();
    return reinterpret_cast<Entry>(module_entry("libpiezo_h5.so", "piezo_h5_library"))();
  }();
  return *loaded;
}

}  // namespace

H5File H5File::create(const std::string& path) {
  return H5File(library().create(path));
}

H5File H5File::create_log(const std::string& path) {
  return H5File(library().create_log(path));
}

H5File H5File::open(const std::string& path) {
  return H5File(library().open(path));
}

}  // namespace piezo::host
