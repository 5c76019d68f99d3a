#pragma once
// A small RAII wrapper over the HDF5 C API: create a file, write 1-D float64
// datasets and string attributes. Errors throw with the object's name;
// HDF5's own error stack printing is silenced.

#include <hdf5.h>

#include <span>
#include <string>
#include <vector>

namespace piezo::host {

/// Owns one HDF5 identifier and closes it with the matching H5*close.
class H5Id {
 public:
  H5Id() = default;
  H5Id(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  H5Id(const H5Id&) = delete;
  H5Id& operator=(const H5Id&) = delete;
  H5Id(H5Id&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = H5I_INVALID_HID; }
  H5Id& operator=(H5Id&& o) noexcept;
  ~H5Id() { reset(); }
  /// Gives up ownership without closing.
  [[nodiscard]] hid_t release() {
    const hid_t id = id_;
    id_ = H5I_INVALID_HID;
    return id;
  }

  void reset();
  [[nodiscard]] hid_t get() const { return id_; }

 private:
  hid_t id_ = H5I_INVALID_HID;
  herr_t (*close_)(hid_t) = nullptr;
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
  void create_growing(const std::string& name, bool small_integers = false);
  /// Appends to a dataset made by create_growing.
  void append(const std::string& name, std::span<const double> values);
  /// Writes everything buffered to the file.
  void flush();
  /// Closes the file now; throws, naming the file and the system's reason,
  /// when the last writes fail (a full disk). The file is closed either way.
  void close();
  /// Lets go of a file that can no longer be written, without the flush a
  /// close would try: HDF5 writes nothing more to it, so the file keeps
  /// what its last good flush put there. For failure paths only.
  void abandon() { (void)file_.release(); }

  /// A whole vector dataset (1-D, or N x 1 as MATLAB writes it), as double.
  [[nodiscard]] std::vector<double> read(const std::string& name) const;
  [[nodiscard]] bool exists(const std::string& name) const;
  /// How many values a vector dataset claims to hold, without reading them
  /// (a damaged file's claim may be more than it can give).
  [[nodiscard]] std::size_t extent(const std::string& name) const;
  /// The values of a 1-D dataset from its start up to the first block of
  /// them that cannot be read (a damaged chunk); all of them when whole.
  [[nodiscard]] std::vector<double> read_prefix(const std::string& name) const;
  /// The names of the attributes of "/" or of an object.
  [[nodiscard]] std::vector<std::string> attribute_names(const std::string& object) const;
  [[nodiscard]] bool has_attribute(const std::string& object, const std::string& name) const;
  /// A string attribute of "/" or of an object.
  [[nodiscard]] std::string attribute(const std::string& object, const std::string& name) const;

  /// Writes a complete 1-D float64 dataset; intermediate groups are created.
  void write(const std::string& name, std::span<const double> values);
  /// Sets a string attribute on the root group ("/") or on an existing object.
  void set_attribute(const std::string& object, const std::string& name, const std::string& value);

  [[nodiscard]] const std::string& path() const { return path_; }

 private:
  H5File(H5Id file, std::string path) : file_(std::move(file)), path_(std::move(path)) {}
  H5Id file_;
  std::string path_;
};

/// Link-creation properties that create missing parent groups.
[[nodiscard]] H5Id intermediate_groups_lcpl();

}  // namespace piezo::host
