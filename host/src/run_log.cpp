#include "run_log.hpp"

namespace piezo::host {

const std::vector<std::string>& RunLog::drive_columns() {
  static const std::vector<std::string> names{"/drive/t", "/drive/V", "/drive/phase",
                                              "/drive/status"};
  return names;
}

const std::vector<std::string>& RunLog::observer_columns() {
  static const std::vector<std::string> names{
      "/observer/t",     "/observer/theta_hat", "/observer/theta_dot_hat", "/observer/x_hat",
      "/observer/z_hat", "/observer/F_hat",     "/observer/residual",      "/observer/theta_open"};
  return names;
}

const std::vector<std::string>& RunLog::sensor_columns() {
  static const std::vector<std::string> names{"/sensor/t", "/sensor/t_response",
                                              "/sensor/displacement_m", "/sensor/theta",
                                              "/sensor/status"};
  return names;
}

RunLog RunLog::create(const std::string& path, const std::map<std::string, std::string>& header) {
  RunLog log(H5File::create_log(path));
  for (const auto& name : drive_columns()) log.file_.create_growing(name);
  for (const auto& name : sensor_columns()) log.file_.create_growing(name);
  for (const auto& name : observer_columns()) log.file_.create_growing(name);
  for (const auto& [name, value] : header) log.file_.set_attribute("/", name, value);
  log.file_.set_attribute("/", "status", "incomplete");
  log.file_.flush();
  return log;
}

void RunLog::append(ColumnBuffer& buffer) {
  for (auto& [name, values] : buffer) {
    file_.append(name, values);
    values.clear();
  }
  file_.flush();
}

void RunLog::write(const std::string& name, std::span<const double> values) {
  file_.write(name, values);
}

void RunLog::set_attribute(const std::string& name, const std::string& value) {
  file_.set_attribute("/", name, value);
}

void RunLog::close(const std::string& status) {
  file_.set_attribute("/", "status", status);
  file_.flush();
}

}  // namespace piezo::host
