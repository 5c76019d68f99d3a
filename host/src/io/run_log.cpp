#include "run_log.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <sys/resource.h>
#include <sys/statvfs.h>

#include <algorithm>
#include <filesystem>
#include <stdexcept>

namespace piezo::host {

RunLog RunLog::create(const std::string& path, std::map<std::string, std::string> header,
                      const std::vector<std::string>& axes) {
  if (axes.empty()) throw std::invalid_argument("a run log needs the run's axes");
  if (!log_schema::at_root(axes))
    header[log_schema::kAxes] = fmt::format("{}", fmt::join(axes, ","));
  RunJournal journal = RunJournal::create(journal_path(path), header);
  RunLog log(H5File::create_log(path), std::move(journal), axes);
  AxesRows none(log.axes_.size());
  log_schema::for_each_column(none, log.axes_, [&](std::string_view dataset, const auto&) {
    log.file_.create_growing(std::string(dataset),
                             log_schema::storage(dataset) == log_schema::Storage::uint8);
  });
  for (const auto& [name, value] : header) log.file_.set_attribute("/", name, value);
  log.file_.set_attribute("/", log_schema::kStatus, "incomplete");
  log.file_.flush();
  return log;
}

namespace {

// Slice `slice` of `slices` over `size` rows: the same rows of every column
// of one group, so the groups' columns stay equally long after each slice.
std::size_t slice_begin(std::size_t size, std::size_t slices, std::size_t slice) {
  return size * slice / slices;
}

std::size_t slice_length(std::size_t size, std::size_t slices, std::size_t slice) {
  return slice_begin(size, slices, slice + 1) - slice_begin(size, slices, slice);
}

}  // namespace

void RunLog::check_room(const std::string& path, std::uintmax_t bytes) const {
  // Room for the samples twice over, a new 64 KiB chunk for every dataset
  // and the close's metadata.
  constexpr std::uintmax_t kReserve = 2u << 20;
  const std::uintmax_t needed = 2 * bytes + kReserve;
  std::error_code error;
  const std::uintmax_t size = std::filesystem::file_size(path, error);
  std::uintmax_t room = UINTMAX_MAX;
  struct statvfs fs {};
  if (statvfs(path.c_str(), &fs) == 0) {
    room = static_cast<std::uintmax_t>(fs.f_bavail) * fs.f_frsize;
  }
  rlimit limit{};
  if (getrlimit(RLIMIT_FSIZE, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY && !error) {
    room = std::min<std::uintmax_t>(room, limit.rlim_cur > size ? limit.rlim_cur - size : 0);
  }
  if (room < needed) {
    throw RoomError(fmt::format(
        "log {}: {} bytes left on its device or under the file-size limit, {} needed to go on "
        "safely; the log ends here",
        path, room, needed));
  }
}

void RunLog::append(LogRows& rows) {
  AxesRows one(1);
  std::swap(one[0], rows);
  try {
    append(one);
  } catch (...) {
    std::swap(one[0], rows);  // what was not written stays in the caller's buffer
    throw;
  }
  std::swap(one[0], rows);
}

void RunLog::append(AxesRows& rows) {
  // Written in slices, each checked for room first, so a log that meets a
  // full disk or a file-size limit keeps every slice that fitted instead of
  // losing the whole flush interval.
  constexpr std::size_t kSliceBytes = 512u << 10;
  std::vector<std::pair<std::string, log_schema::Column*>> buffer;
  log_schema::for_each_column(rows, axes_, [&](std::string_view path, log_schema::Column& column) {
    buffer.emplace_back(path, &column);
  });
  std::size_t total = 0;
  for (const auto& [name, values] : buffer) total += values->size() * sizeof(double);
  const std::size_t slices = std::max<std::size_t>(1, (total + kSliceBytes - 1) / kSliceBytes);
  std::size_t written = 0;
  const auto drop_written = [&] {
    for (auto& [name, values] : buffer) {
      values->erase(values->begin(), values->begin() + static_cast<std::ptrdiff_t>(slice_begin(
                                                           values->size(), slices, written)));
    }
  };
  try {
    for (; written < slices; ++written) {
      // The slice goes to the journal (and the disk) first, then to the file.
      AxesRows slice(rows.size());
      std::size_t column = 0, values_in_slice = 0;
      log_schema::for_each_column(slice, axes_, [&](std::string_view, log_schema::Column& part) {
        const log_schema::Column& values = *buffer[column++].second;
        const auto begin = values.begin() +
                           static_cast<std::ptrdiff_t>(slice_begin(values.size(), slices, written));
        part.assign(begin, begin + static_cast<std::ptrdiff_t>(
                                       slice_length(values.size(), slices, written)));
        values_in_slice += part.size();
      });
      check_room(journal_.path(), RunJournal::bound(values_in_slice));
      journal_.append(slice, axes_);
      check_room(file_.path(), values_in_slice * sizeof(double));
      for (auto& [name, values] : buffer) {
        file_.append(name, std::span<const double>(*values).subspan(
                               slice_begin(values->size(), slices, written),
                               slice_length(values->size(), slices, written)));
      }
      file_.flush();
    }
  } catch (const RoomError&) {
    refused_ = true;  // the journal may hold a slice the file refused
    drop_written();   // the refused slice wrote nothing to the file: it stays whole
    throw;
  } catch (...) {
    broken_ = true;
    throw;
  }
  for (auto& [name, values] : buffer) values->clear();
}

void RunLog::write(const std::string& name, std::span<const double> values) {
  file_.write(name, values);
}

void RunLog::set_attribute(const std::string& name, const std::string& value) {
  try {
    journal_.set_attribute(name, value);
  } catch (const std::exception&) {
    // The file is what a closed run is read from; the journal only has to
    // hold the rows.
  }
  file_.set_attribute("/", name, value);
}

void RunLog::set_axis_attribute(std::size_t axis, const std::string& name,
                                const std::string& value) {
  const std::string group = log_schema::axis_group(axes_, axis);
  if (group.empty()) {  // a recovered log of the layout before /axes
    set_attribute(name, value);
    return;
  }
  try {
    // Kept in the journal under the attribute's path (recovery puts it back).
    journal_.set_attribute(group + "/" + name, value);
  } catch (const std::exception&) {
    // As set_attribute: the journal only has to hold the rows.
  }
  file_.set_attribute(group, name, value);
}

void RunLog::close(const std::string& status) {
  if (broken_) {
    abandon();
    throw std::runtime_error("log " + file_.path() + ": not closed after a failed write");
  }
  try {
    file_.set_attribute("/", log_schema::kStatus, status);
    file_.flush();
  } catch (...) {
    broken_ = true;
    abandon();
    throw;
  }
  file_.close();
  if (!refused_) journal_.remove();
}

void RunLog::abandon() noexcept {
  file_.abandon();
}

}  // namespace piezo::host
