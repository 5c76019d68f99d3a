#include "spill_file.hpp"

#include <filesystem>
#include <stdexcept>
#include <vector>

namespace piezo::daemon {

SpillFile::SpillFile(std::string path) : path_(std::move(path)) {
  // A daemon that crashed mid-run left its run's samples here: keep them
  // for `piezo recover --spill` instead of truncating them away.
  std::error_code ignored;
  if (std::filesystem::file_size(path_, ignored) > 0 && !ignored) {
    std::filesystem::rename(path_, path_ + ".previous", ignored);
  }
  clear();
}

void SpillFile::clear() {
  file_.close();
  file_.open(path_, std::ios::in | std::ios::out | std::ios::binary | std::ios::trunc);
  if (!file_) throw std::runtime_error("piezod.spill_file: cannot write " + path_);
}

void SpillFile::append(std::string_view frame) {
  file_.seekp(0, std::ios::end);
  const auto n = static_cast<std::uint32_t>(frame.size());
  const char length[4] = {static_cast<char>(n), static_cast<char>(n >> 8),
                          static_cast<char>(n >> 16), static_cast<char>(n >> 24)};
  file_.write(length, 4);
  file_.write(frame.data(), static_cast<std::streamsize>(frame.size()));
  file_.flush();
}

std::optional<std::string> SpillFile::fetch(protocol::Stream stream, std::uint64_t first,
                                            std::uint64_t count) {
  file_.clear();
  file_.seekg(0);
  std::vector<firmware::DriveSample> drive;
  std::vector<firmware::SensorSample> sensor;
  std::uint64_t next = first;
  bool found = false;
  std::string frame;
  for (char length[4]; next < first + count && file_.read(length, 4);) {
    const std::uint32_t n = static_cast<std::uint8_t>(length[0]) |
                            static_cast<std::uint32_t>(static_cast<std::uint8_t>(length[1])) << 8 |
                            static_cast<std::uint32_t>(static_cast<std::uint8_t>(length[2])) << 16 |
                            static_cast<std::uint32_t>(static_cast<std::uint8_t>(length[3])) << 24;
    frame.resize(n);
    if (!file_.read(frame.data(), n)) break;
    const auto h = protocol::decode_header(frame);
    if (h.stream != stream || h.first_seq + h.count <= next || h.first_seq > next) continue;
    found = true;
    const std::size_t skip = next - h.first_seq;
    const std::size_t take = std::min<std::uint64_t>(h.count - skip, first + count - next);
    if (stream == protocol::Stream::drive) {
      const auto samples = protocol::decode_drive(frame);
      drive.insert(drive.end(), samples.begin() + static_cast<long>(skip),
                   samples.begin() + static_cast<long>(skip + take));
    } else {
      const auto samples = protocol::decode_sensor(frame);
      sensor.insert(sensor.end(), samples.begin() + static_cast<long>(skip),
                    samples.begin() + static_cast<long>(skip + take));
    }
    next += take;
  }
  file_.clear();
  if (!found) return std::nullopt;
  return stream == protocol::Stream::drive ? protocol::encode_frame(first, drive)
                                           : protocol::encode_frame(first, sensor);
}

}  // namespace piezo::daemon
