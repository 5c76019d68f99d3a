#pragma once
// A small HDF5 file API: create a file, write 1-D float64 datasets and string
// attributes, read them back. Errors throw std::runtime_error with the
// object's name; HDF5's own error stack printing is silenced.
//
// The HDF5 library is loaded when a program first creates or opens a file
// (the module libpiezo_h5.so, hdf5_store.cpp): with what it pulls in (curl,
// Kerberos, TLS) it costs some 9 ms of every start-up, and most `piezo`
// commands (`--help`, `simulate` without --out) never open a file. A program
// that links hdf5_store.cpp (the Python module) uses it without loading.

#include <cstddef>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace piezo::host {

/// One open file, on the HDF5 side (hdf5_store.cpp); H5File's methods say
/// what each does.
class H5Store {
 public:
  virtual ~H5Store() = default;
  virtual void create_growing(const std::string& name, bool small_integers) = 0;
  virtual void append(const std::string& name, std::span<const double> values) = 0;
  virtual void flush() = 0;
  virtual void close() = 0;
  virtual void abandon() = 0;
  [[nodiscard]] virtual std::vector<double> read(const std::string& name) const = 0;
  [[nodiscard]] virtual bool exists(const std::string& name) const = 0;
  [[nodiscard]] virtual std::size_t extent(const std::string& name) const = 0;
  [[nodiscard]] virtual std::vector<double> read_prefix(const std::string& name) const = 0;
  [[nodiscard]] virtual std::vector<std::string> attribute_names(
      const std::string& object) const = 0;
  [[nodiscard]] virtual bool has_attribute(const std::string& object,
                                           const std::string& name) const = 0;
  [[nodiscard]] virtual std::string attribute(const std::string& object,
                                              const std::string& name) const = 0;
  virtual void write(const std::string& name, std::span<const double> values) = 0;
  virtual void set_attribute(const std::string& object, const std::string& name,
                             const std::string& value) = 0;
  [[nodiscard]] virtual const std::string& path() const = 0;
  [[nodiscard]] virtual std::string unreachable_objects() const = 0;
};

/// What the HDF5 side offers: its entry point, `piezo_h5_library`.
struct H5Library {
  std::unique_ptr<H5Store> (*create)(const std::string& path);
  std::unique_ptr<H5Store> (*create_log)(const std::string& path);
  std::unique_ptr<H5Store> (*open)(const std::string& path);
};

class H5File {
 public:
  /// Creates (truncates) `path`.
  static H5File create(const std::string& path);
  /// Creates `path` for a log that grows while it is written. Dirty metadata
  /// stays in memory until flush(), so that between flushes only new raw data
  /// reaches the disk and the last flushed state stays readable after a crash.
  static H5File create_log(const std::string& path);
  /// Opens an existing file read-only.
  static H5File open(const std::string& path);

  /// Creates an empty, unlimited, chunked 1-D float64 dataset.
  /// `small_integers`: stored as uint8 (codes 0..255), else float64.
  /// Shuffled and deflated: h5py and MATLAB read it without plugins.
  void create_growing(const std::string& name, bool small_integers = false) {
    store_->create_growing(name, small_integers);
  }
  /// Appends to a dataset made by create_growing.
  void append(const std::string& name, std::span<const double> values) {
    store_->append(name, values);
  }
  /// Writes everything buffered to the file.
  void flush() { store_->flush(); }
  /// Closes the file now; throws, naming the file and the system's reason,
  /// when the last writes fail (a full disk). The file is closed either way.
  void close() { store_->close(); }
  /// Lets go of a file that can no longer be written, without the flush a
  /// close would try: HDF5 writes nothing more to it, so the file keeps
  /// what its last good flush put there. For failure paths only.
  void abandon() { store_->abandon(); }

  /// A whole vector dataset (1-D, or N x 1 as MATLAB writes it), as double.
  [[nodiscard]] std::vector<double> read(const std::string& name) const {
    return store_->read(name);
  }
  [[nodiscard]] bool exists(const std::string& name) const { return store_->exists(name); }
  /// How many values a vector dataset claims to hold, without reading them
  /// (a damaged file's claim may be more than it can give).
  [[nodiscard]] std::size_t extent(const std::string& name) const { return store_->extent(name); }
  /// The values of a 1-D dataset from its start up to the first block of
  /// them that cannot be read (a damaged chunk); all of them when whole.
  [[nodiscard]] std::vector<double> read_prefix(const std::string& name) const {
    return store_->read_prefix(name);
  }
  /// The names of the attributes of "/" or of an object.
  [[nodiscard]] std::vector<std::string> attribute_names(const std::string& object) const {
    return store_->attribute_names(object);
  }
  [[nodiscard]] bool has_attribute(const std::string& object, const std::string& name) const {
    return store_->has_attribute(object, name);
  }
  /// A string attribute of "/" or of an object.
  [[nodiscard]] std::string attribute(const std::string& object, const std::string& name) const {
    return store_->attribute(object, name);
  }
  /// Writes a complete 1-D float64 dataset; intermediate groups are created.
  void write(const std::string& name, std::span<const double> values) {
    store_->write(name, values);
  }
  /// Sets a string attribute on the root group ("/") or on an existing object.
  void set_attribute(const std::string& object, const std::string& name, const std::string& value) {
    store_->set_attribute(object, name, value);
  }
  [[nodiscard]] const std::string& path() const { return store_->path(); }
  /// Why a walk of every object in the file (every group's links, as a
  /// generic reader such as h5py's visititems takes them) fails; empty
  /// when it reaches them all. A damaged group's name heap fails it, while
  /// the datasets opened by their paths still read.
  [[nodiscard]] std::string unreachable_objects() const { return store_->unreachable_objects(); }

 private:
  explicit H5File(std::unique_ptr<H5Store> store) : store_(std::move(store)) {}
  std::unique_ptr<H5Store> store_;
};

}  // namespace piezo::host
