// The HDF5 side of H5File (h5_file.hpp): built into the module
// libpiezo_h5.so that H5File loads when a program first opens a file, or
// linked into a program that always needs it (the Python module).
#include <fmt/format.h>
#include <hdf5.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <memory>
#include <stdexcept>

#include "h5_file.hpp"

namespace piezo::host {
namespace {

// Files are closed by their owners. HDF5's own clean-up at exit would close
// again a file whose close failed (a full disk) and crash the process
// (HDF5 1.10, H5F__close_cb): it is turned off before the first HDF5 call.
const bool kNoCleanupAtExit = [] {
  H5dont_atexit();
  return true;
}();

/// Owns one HDF5 identifier and closes it with the matching H5*close.
class H5Id {
 public:
  H5Id() = default;
  H5Id(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  H5Id(const H5Id&) = delete;
  H5Id& operator=(const H5Id&) = delete;
  H5Id(H5Id&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = H5I_INVALID_HID; }
  H5Id& operator=(H5Id&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = o.id_;
      close_ = o.close_;
      o.id_ = H5I_INVALID_HID;
    }
    return *this;
  }
  ~H5Id() { reset(); }
  /// Gives up ownership without closing.
  [[nodiscard]] hid_t release() {
    const hid_t id = id_;
    id_ = H5I_INVALID_HID;
    return id;
  }
  void reset() {
    if (id_ >= 0 && close_ != nullptr) close_(id_);
    id_ = H5I_INVALID_HID;
  }
  [[nodiscard]] hid_t get() const { return id_; }

 private:
  hid_t id_ = H5I_INVALID_HID;
  herr_t (*close_)(hid_t) = nullptr;
};

hid_t checked(hid_t id, const std::string& what) {
  if (id < 0) throw std::runtime_error("HDF5: cannot " + what);
  return id;
}

/// Link-creation properties that create missing parent groups.
H5Id intermediate_groups_lcpl() {
  H5Id lcpl(checked(H5Pcreate(H5P_LINK_CREATE), "create link properties"), H5Pclose);
  H5Pset_create_intermediate_group(lcpl.get(), 1);
  return lcpl;
}

std::string system_reason() {
  return errno != 0 ? std::string(": ") + std::strerror(errno) : std::string();
}

/// One open file.
class Hdf5Store final : public H5Store {
 public:
  Hdf5Store(H5Id file, std::string path) : file_(std::move(file)), path_(std::move(path)) {}

  void create_growing(const std::string& name, bool small_integers) override;
  void append(const std::string& name, std::span<const double> values) override;
  void flush() override;
  void close() override;
  void abandon() override { (void)file_.release(); }
  [[nodiscard]] std::vector<double> read(const std::string& name) const override;
  [[nodiscard]] bool exists(const std::string& name) const override;
  [[nodiscard]] std::size_t extent(const std::string& name) const override;
  [[nodiscard]] std::vector<double> read_prefix(const std::string& name) const override;
  [[nodiscard]] std::vector<std::string> attribute_names(const std::string& object) const override;
  [[nodiscard]] bool has_attribute(const std::string& object,
                                   const std::string& name) const override;
  [[nodiscard]] std::string attribute(const std::string& object,
                                      const std::string& name) const override;
  void write(const std::string& name, std::span<const double> values) override;
  void set_attribute(const std::string& object, const std::string& name,
                     const std::string& value) override;
  [[nodiscard]] const std::string& path() const override { return path_; }
  [[nodiscard]] std::string unreachable_objects() const override;

 private:
  H5Id file_;
  std::string path_;
};

std::unique_ptr<H5Store> create_file(const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  H5Id file(
      checked(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), "create " + path),
      H5Fclose);
  return std::make_unique<Hdf5Store>(std::move(file), path);
}

std::unique_ptr<H5Store> create_log_file(const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  H5Id fapl(checked(H5Pcreate(H5P_FILE_ACCESS), "create file access properties"), H5Pclose);
  H5AC_cache_config_t cache{};
  cache.version = H5AC__CURR_CACHE_CONFIG_VERSION;
  H5Pget_mdc_config(fapl.get(), &cache);
  cache.evictions_enabled = false;
  cache.incr_mode = H5C_incr__off;
  cache.flash_incr_mode = H5C_flash_incr__off;
  cache.decr_mode = H5C_decr__off;
  if (H5Pset_mdc_config(fapl.get(), &cache) < 0) {
    throw std::runtime_error("HDF5: cannot configure the metadata cache for " + path);
  }
  H5Id file(
      checked(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get()), "create " + path),
      H5Fclose);
  return std::make_unique<Hdf5Store>(std::move(file), path);
}

std::unique_ptr<H5Store> open_file(const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  H5Id file(checked(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), "open " + path), H5Fclose);
  return std::make_unique<Hdf5Store>(std::move(file), path);
}

void Hdf5Store::create_growing(const std::string& name, bool small_integers) {
  constexpr hsize_t kChunk = 8192;  // 64 KiB of float64: few chunks, cheap appends
  // Byte shuffle then deflate: times and slowly varying values compress well
  // once their bytes are grouped; level 4 keeps a flush cheap.
  constexpr unsigned kDeflateLevel = 4;
  const hsize_t dims[1] = {0};
  const hsize_t max_dims[1] = {H5S_UNLIMITED};
  H5Id space(checked(H5Screate_simple(1, dims, max_dims), "create dataspace for " + name),
             H5Sclose);
  H5Id dcpl(checked(H5Pcreate(H5P_DATASET_CREATE), "create dataset properties"), H5Pclose);
  const hsize_t chunk[1] = {kChunk};
  H5Pset_chunk(dcpl.get(), 1, chunk);
  H5Pset_shuffle(dcpl.get());
  H5Pset_deflate(dcpl.get(), kDeflateLevel);
  H5Id lcpl = intermediate_groups_lcpl();
  H5Id dset(
      checked(H5Dcreate2(file_.get(), name.c_str(), small_integers ? H5T_STD_U8LE : H5T_IEEE_F64LE,
                         space.get(), lcpl.get(), dcpl.get(), H5P_DEFAULT),
              "create dataset " + name),
      H5Dclose);
}

void Hdf5Store::append(const std::string& name, std::span<const double> values) {
  if (values.empty()) return;
  H5Id dset(checked(H5Dopen2(file_.get(), name.c_str(), H5P_DEFAULT), "open dataset " + name),
            H5Dclose);
  H5Id old_space(checked(H5Dget_space(dset.get()), "get dataspace of " + name), H5Sclose);
  hsize_t old_size[1] = {0};
  H5Sget_simple_extent_dims(old_space.get(), old_size, nullptr);
  const hsize_t new_size[1] = {old_size[0] + values.size()};
  if (H5Dset_extent(dset.get(), new_size) < 0)
    throw std::runtime_error("HDF5: cannot extend " + name);
  H5Id file_space(checked(H5Dget_space(dset.get()), "get dataspace of " + name), H5Sclose);
  const hsize_t count[1] = {values.size()};
  H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, old_size, nullptr, count, nullptr);
  H5Id mem_space(checked(H5Screate_simple(1, count, nullptr), "create memory space"), H5Sclose);
  if (H5Dwrite(dset.get(), H5T_NATIVE_DOUBLE, mem_space.get(), file_space.get(), H5P_DEFAULT,
               values.data()) < 0) {
    throw std::runtime_error("HDF5: cannot append to " + name);
  }
}

void Hdf5Store::flush() {
  errno = 0;
  if (H5Fflush(file_.get(), H5F_SCOPE_LOCAL) < 0)
    throw std::runtime_error("HDF5: cannot flush " + path_ + system_reason());
}

void Hdf5Store::close() {
  const hid_t id = file_.release();
  errno = 0;
  if (id >= 0 && H5Fclose(id) < 0) {
    throw std::runtime_error("HDF5: cannot close " + path_ + system_reason());
  }
}

bool Hdf5Store::exists(const std::string& name) const {
  return H5Lexists(file_.get(), name.c_str(), H5P_DEFAULT) > 0;
}

std::size_t Hdf5Store::extent(const std::string& name) const {
  H5Id dset(checked(H5Dopen2(file_.get(), name.c_str(), H5P_DEFAULT), "open dataset " + name),
            H5Dclose);
  H5Id space(checked(H5Dget_space(dset.get()), "get dataspace of " + name), H5Sclose);
  const hssize_t n = H5Sget_simple_extent_npoints(space.get());
  if (n < 0) throw std::runtime_error("HDF5: cannot get the size of " + name);
  return static_cast<std::size_t>(n);
}

std::vector<double> Hdf5Store::read_prefix(const std::string& name) const {
  H5Id dset(checked(H5Dopen2(file_.get(), name.c_str(), H5P_DEFAULT), "open dataset " + name),
            H5Dclose);
  H5Id space(checked(H5Dget_space(dset.get()), "get dataspace of " + name), H5Sclose);
  if (H5Sget_simple_extent_ndims(space.get()) != 1) {
    throw std::runtime_error("HDF5: " + name + " is not one-dimensional");
  }
  hsize_t claimed = 0;
  H5Sget_simple_extent_dims(space.get(), &claimed, nullptr);
  // No more than the file's bytes could hold (see read()).
  hsize_t file_bytes = 0;
  H5Fget_filesize(file_.get(), &file_bytes);
  const hsize_t possible = std::min<hsize_t>(claimed, 1100 * (file_bytes / sizeof(double) + 1));
  // Block by block, in the log's chunk size: a damaged chunk ends the prefix.
  constexpr hsize_t kBlock = 8192;
  std::vector<double> out;
  for (hsize_t start = 0; start < possible; start += kBlock) {
    const hsize_t count = std::min(kBlock, possible - start);
    H5Id memory(checked(H5Screate_simple(1, &count, nullptr), "create dataspace"), H5Sclose);
    if (H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, &start, nullptr, &count, nullptr) < 0) {
      break;
    }
    std::vector<double> block(count);
    if (H5Dread(dset.get(), H5T_NATIVE_DOUBLE, memory.get(), space.get(), H5P_DEFAULT,
                block.data()) < 0) {
      break;
    }
    out.insert(out.end(), block.begin(), block.end());
  }
  return out;
}

std::string Hdf5Store::unreachable_objects() const {
  const auto reached = [](hid_t, const char*, const H5O_info_t*, void*) -> herr_t { return 0; };
  if (H5Ovisit2(file_.get(), H5_INDEX_NAME, H5_ITER_NATIVE, reached, nullptr, H5O_INFO_BASIC) < 0) {
    return "HDF5: not every object of " + path_ + " can be reached from its root";
  }
  return "";
}

std::vector<std::string> Hdf5Store::attribute_names(const std::string& object) const {
  std::vector<std::string> names;
  const auto collect = [](hid_t, const char* name, const H5A_info_t*, void* out) -> herr_t {
    static_cast<std::vector<std::string>*>(out)->emplace_back(name);
    return 0;
  };
  if (H5Aiterate_by_name(file_.get(), object.c_str(), H5_INDEX_NAME, H5_ITER_NATIVE, nullptr,
                         collect, &names, H5P_DEFAULT) < 0) {
    throw std::runtime_error("HDF5: cannot list the attributes of " + object);
  }
  return names;
}

std::vector<double> Hdf5Store::read(const std::string& name) const {
  H5Id dset(checked(H5Dopen2(file_.get(), name.c_str(), H5P_DEFAULT), "open dataset " + name),
            H5Dclose);
  H5Id space(checked(H5Dget_space(dset.get()), "get dataspace of " + name), H5Sclose);
  // A vector: 1-D, or 2-D with one side 1 (MATLAB writes its column vectors
  // as 1 x N in HDF5).
  const int rank = H5Sget_simple_extent_ndims(space.get());
  hsize_t size[2] = {0, 1};
  if (rank == 1 || rank == 2) H5Sget_simple_extent_dims(space.get(), size, nullptr);
  if ((rank != 1 && rank != 2) || (rank == 2 && size[0] != 1 && size[1] != 1)) {
    throw std::runtime_error("HDF5: " + name + " is not a vector (one-dimensional, or N x 1)");
  }
  const hsize_t elements = size[0] * (rank == 2 ? size[1] : 1);
  // A damaged file can claim any length. Deflate packs at most about 1032
  // to 1, so a dataset cannot hold more values than that many times the
  // file's bytes; past that the header is wrong, not the memory short.
  hsize_t file_bytes = 0;
  H5Fget_filesize(file_.get(), &file_bytes);
  if (elements > 1100 * (file_bytes / sizeof(double) + 1)) {
    throw std::runtime_error(fmt::format(
        "HDF5: {} in {} claims {} values, more than its {} bytes can hold: the file is damaged",
        name, path_, elements, file_bytes));
  }
  std::vector<double> out(elements);
  if (!out.empty() &&
      H5Dread(dset.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0) {
    throw std::runtime_error("HDF5: cannot read " + name);
  }
  return out;
}

bool Hdf5Store::has_attribute(const std::string& object, const std::string& name) const {
  return H5Aexists_by_name(file_.get(), object.c_str(), name.c_str(), H5P_DEFAULT) > 0;
}

std::string Hdf5Store::attribute(const std::string& object, const std::string& name) const {
  H5Id attr(
      checked(H5Aopen_by_name(file_.get(), object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT),
              "open attribute " + name),
      H5Aclose);
  H5Id type(checked(H5Aget_type(attr.get()), "get type of attribute " + name), H5Tclose);
  if (H5Tget_class(type.get()) != H5T_STRING || H5Tis_variable_str(type.get()) > 0) {
    throw std::runtime_error("HDF5: attribute " + name + " is not a fixed-length string");
  }
  std::string value(H5Tget_size(type.get()), '\0');
  if (H5Aread(attr.get(), type.get(), value.data()) < 0) {
    throw std::runtime_error("HDF5: cannot read attribute " + name);
  }
  value.resize(value.find('\0') == std::string::npos ? value.size() : value.find('\0'));
  return value;
}

void Hdf5Store::write(const std::string& name, std::span<const double> values) {
  const hsize_t dims[1] = {values.size()};
  H5Id space(checked(H5Screate_simple(1, dims, nullptr), "create dataspace for " + name), H5Sclose);
  H5Id lcpl = intermediate_groups_lcpl();
  H5Id dset(checked(H5Dcreate2(file_.get(), name.c_str(), H5T_IEEE_F64LE, space.get(), lcpl.get(),
                               H5P_DEFAULT, H5P_DEFAULT),
                    "create dataset " + name),
            H5Dclose);
  if (!values.empty() &&
      H5Dwrite(dset.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) < 0) {
    throw std::runtime_error("HDF5: cannot write dataset " + name);
  }
}

void Hdf5Store::set_attribute(const std::string& object, const std::string& name,
                              const std::string& value) {
  H5Id type(checked(H5Tcopy(H5T_C_S1), "copy string type"), H5Tclose);
  H5Tset_size(type.get(), value.empty() ? 1 : value.size());
  H5Tset_cset(type.get(), H5T_CSET_UTF8);
  H5Id space(checked(H5Screate(H5S_SCALAR), "create scalar space"), H5Sclose);
  if (H5Aexists_by_name(file_.get(), object.c_str(), name.c_str(), H5P_DEFAULT) > 0) {
    H5Adelete_by_name(file_.get(), object.c_str(), name.c_str(), H5P_DEFAULT);
  }
  H5Id attr(checked(H5Acreate_by_name(file_.get(), object.c_str(), name.c_str(), type.get(),
                                      space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                    "create attribute " + name),
            H5Aclose);
  const char* data = value.empty() ? "" : value.c_str();
  if (H5Awrite(attr.get(), type.get(), data) < 0) {
    throw std::runtime_error("HDF5: cannot write attribute " + name);
  }
}

constexpr H5Library kLibrary{create_file, create_log_file, open_file};

}  // namespace
}  // namespace piezo::host

extern "C" const piezo::host::H5Library* piezo_h5_library() {
  return &piezo::host::kLibrary;
}
