#include "piezo/hal/gpiod/gpiod_lines.hpp"

#include <fcntl.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <stdexcept>

namespace piezo::hal::gpiod {
namespace {

gpiod_chip* open_chip(const std::string& chip) {
  gpiod_chip* c = gpiod_chip_open_lookup(chip.c_str());
  if (c == nullptr) {
    throw std::runtime_error("gpio: cannot open chip " + chip + ": " + std::strerror(errno));
  }
  return c;
}

}  // namespace

GpiodOutputs::GpiodOutputs(const std::string& chip, const std::vector<unsigned>& offsets,
                           const std::vector<int>& initial_levels, const std::string& consumer)
    : chip_(open_chip(chip)), size_(offsets.size()) {
  if (initial_levels.size() != offsets.size()) {
    gpiod_chip_close(chip_);
    throw std::invalid_argument("gpio: one initial level per output line is needed");
  }
  if (offsets.empty() || offsets.size() > GPIOD_LINE_BULK_MAX_LINES ||
      gpiod_chip_get_lines(chip_, const_cast<unsigned*>(offsets.data()),
                           static_cast<unsigned>(offsets.size()), &bulk_) != 0 ||
      gpiod_line_request_bulk_output(&bulk_, consumer.c_str(), initial_levels.data()) != 0) {
    const std::string why = std::strerror(errno);
    gpiod_chip_close(chip_);
    throw std::runtime_error("gpio: cannot request output lines on " + chip + ": " + why);
  }
}

GpiodOutputs::~GpiodOutputs() {
  gpiod_line_release_bulk(&bulk_);
  gpiod_chip_close(chip_);
}

Status GpiodOutputs::set_levels(std::span<const int> levels) {
  if (levels.size() != size_) return Status::io_error;
  return gpiod_line_set_value_bulk(&bulk_, levels.data()) == 0 ? Status::ok : Status::io_error;
}

GpiodEdgeInput::GpiodEdgeInput(const std::string& chip, unsigned offset,
                               const std::string& consumer)
    : chip_(open_chip(chip)) {
  line_ = gpiod_chip_get_line(chip_, offset);
  if (line_ == nullptr || gpiod_line_request_both_edges_events(line_, consumer.c_str()) != 0) {
    const std::string why = std::strerror(errno);
    gpiod_chip_close(chip_);
    throw std::runtime_error("gpio: cannot request edge events on " + chip + " line " +
                             std::to_string(offset) + ": " + why);
  }
  // Two threads take events (the loop and the e-stop watcher): a read that
  // finds the event gone must return at once, not block the loop.
  const int fd = gpiod_line_event_get_fd(line_);
  if (fd < 0 || fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK) != 0) {
    const std::string why = std::strerror(errno);
    gpiod_line_release(line_);
    gpiod_chip_close(chip_);
    throw std::runtime_error("gpio: cannot make line " + std::to_string(offset) +
                             " events non-blocking: " + why);
  }
}

GpiodEdgeInput::~GpiodEdgeInput() {
  gpiod_line_release(line_);
  gpiod_chip_close(chip_);
}

Status GpiodEdgeInput::level(int& level) {
  const int v = gpiod_line_get_value(line_);
  if (v < 0) return Status::io_error;
  level = v;
  return Status::ok;
}

Status GpiodEdgeInput::wait_for_edge(std::int64_t timeout_ns, bool& ready) {
  const timespec timeout{static_cast<time_t>(timeout_ns / 1'000'000'000),
                         static_cast<long>(timeout_ns % 1'000'000'000)};
  const int result = gpiod_line_event_wait(line_, &timeout);
  ready = result > 0;
  return result < 0 ? Status::io_error : Status::ok;
}

Status GpiodEdgeInput::take_edges(int& count) {
  count = 0;
  const timespec no_wait{0, 0};
  for (;;) {
    const int ready = gpiod_line_event_wait(line_, &no_wait);
    if (ready < 0) return Status::io_error;
    if (ready == 0) return Status::ok;
    gpiod_line_event event{};
    if (gpiod_line_event_read(line_, &event) != 0) {
      return errno == EAGAIN ? Status::ok : Status::io_error;  // the other reader took it
    }
    last_edge_ns_ = static_cast<std::int64_t>(event.ts.tv_sec) * 1'000'000'000 + event.ts.tv_nsec;
    ++count;
  }
}

}  // namespace piezo::hal::gpiod
