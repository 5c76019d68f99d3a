#include "h5_file.hpp"

#include <stdexcept>

namespace piezo::host {

H5Id& H5Id::operator=(H5Id&& o) noexcept {
  if (this != &o) {
    reset();
    id_ = o.id_;
    close_ = o.close_;
    o.id_ = H5I_INVALID_HID;
  }
  return *this;
}

void H5Id::reset() {
  if (id_ >= 0 && close_ != nullptr) close_(id_);
  id_ = H5I_INVALID_HID;
}

namespace {
hid_t checked(hid_t id, const std::string& what) {
  if (id < 0) throw std::runtime_error("HDF5: cannot " + what);
  return id;
}
}  // namespace

H5Id intermediate_groups_lcpl() {
  H5Id lcpl(checked(H5Pcreate(H5P_LINK_CREATE), "create link properties"), H5Pclose);
  H5Pset_create_intermediate_group(lcpl.get(), 1);
  return lcpl;
}

H5File H5File::create(const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  H5Id file(
      checked(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), "create " + path),
      H5Fclose);
  return H5File(std::move(file), path);
}

void H5File::write(const std::string& name, std::span<const double> values) {
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

void H5File::set_attribute(const std::string& object, const std::string& name,
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

}  // namespace piezo::host
