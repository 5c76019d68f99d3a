#include "run_journal.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/file.h>
#include <unistd.h>
#include <zlib.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string_view>
#include <utility>
#include <vector>

#include "piezo/config/config_error.hpp"

namespace piezo::host {
namespace fs = std::filesystem;
namespace {

constexpr std::uint32_t kMagic = 0x314a5a50;  // "PZJ1" read as little-endian u32
constexpr std::size_t kBlockHeader = 17;
enum Kind : std::uint8_t { kHeader = 1, kRows = 2, kAttribute = 3 };

// Both the board (arm64) and the PC (x86-64) are little-endian: integers
// and doubles are stored as they are in memory.
template <class T>
void put(std::string& out, T value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof value);
}

void put_string(std::string& out, std::string_view s) {
  put(out, static_cast<std::uint32_t>(s.size()));
  out.append(s);
}

/// Reads from a block's plain bytes; a short block throws (it cannot
/// happen past a good CRC, except in a journal from another program).
class Reader {
 public:
  explicit Reader(std::string_view bytes) : bytes_(bytes) {}
  template <class T>
  T get() {
    T value;
    std::memcpy(&value, take(sizeof value).data(), sizeof value);
    return value;
  }
  std::string get_string() { return std::string(take(get<std::uint32_t>())); }
  std::string_view take(std::size_t n) {
    if (n > bytes_.size()) throw std::runtime_error("block shorter than its contents");
    const std::string_view part = bytes_.substr(0, n);
    bytes_.remove_prefix(n);
    return part;
  }
  [[nodiscard]] bool done() const { return bytes_.empty(); }

 private:
  std::string_view bytes_;
};

std::string key_values(const std::map<std::string, std::string>& map) {
  std::string out;
  for (const auto& [key, value] : map) {
    put_string(out, key);
    put_string(out, value);
  }
  return out;
}

void read_key_values(std::string_view plain, std::map<std::string, std::string>& into) {
  Reader r(plain);
  while (!r.done()) {
    std::string key = r.get_string();
    into[key] = r.get_string();
  }
}

std::uint32_t block_crc(std::uint8_t kind, std::uint32_t stored, std::uint32_t plain,
                        std::string_view bytes) {
  std::string head;
  put(head, kind);
  put(head, stored);
  put(head, plain);
  uLong crc = crc32(0L, Z_NULL, 0);
  crc = crc32(crc, reinterpret_cast<const Bytef*>(head.data()), static_cast<uInt>(head.size()));
  crc = crc32(crc, reinterpret_cast<const Bytef*>(bytes.data()), static_cast<uInt>(bytes.size()));
  return static_cast<std::uint32_t>(crc);
}

[[noreturn]] void fail(const std::string& path, const char* what) {
  throw std::runtime_error(fmt::format("journal {}: {}: {}", path, what, std::strerror(errno)));
}

}  // namespace

RunJournal RunJournal::create(const std::string& path,
                              const std::map<std::string, std::string>& header) {
  RunJournal j;
  j.path_ = path;
  j.fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_APPEND | O_CLOEXEC, 0644);
  if (j.fd_ < 0) fail(path, "cannot create");
  // Held while the run writes: recovery must not rebuild a live run's log.
  if (flock(j.fd_, LOCK_EX | LOCK_NB) != 0) fail(path, "cannot lock");
  j.write_block(kHeader, key_values(header));
  return j;
}

RunJournal::RunJournal(RunJournal&& o) noexcept
    : fd_(std::exchange(o.fd_, -1)), path_(std::move(o.path_)) {}

RunJournal& RunJournal::operator=(RunJournal&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(o.fd_, -1);
    path_ = std::move(o.path_);
  }
  return *this;
}

RunJournal::~RunJournal() {
  if (fd_ >= 0) ::close(fd_);
}

std::size_t RunJournal::bound(std::size_t values) {
  // Paths and counts of ~20 datasets, the values, deflate's worst case.
  return kBlockHeader + compressBound(static_cast<uLong>(values * sizeof(double) + 4096));
}

void RunJournal::append(log_schema::AxesRows& rows, const std::vector<std::string>& axes) {
  std::string plain;
  log_schema::for_each_column(rows, axes, [&](std::string_view path, const log_schema::Column& c) {
    put_string(plain, path);
    put(plain, static_cast<std::uint64_t>(c.size()));
    plain.append(reinterpret_cast<const char*>(c.data()), c.size() * sizeof(double));
  });
  write_block(kRows, plain);
}

void RunJournal::set_attribute(const std::string& name, const std::string& value) {
  write_block(kAttribute, key_values({{name, value}}));
}

void RunJournal::write_block(std::uint8_t kind, const std::string& plain) {
  if (fd_ < 0) throw std::runtime_error("journal " + path_ + ": not open");
  uLongf stored = compressBound(static_cast<uLong>(plain.size()));
  std::string block(kBlockHeader + stored, '\0');
  // Level 1: the journal is written on every flush; run.h5 is the archive.
  if (compress2(reinterpret_cast<Bytef*>(block.data() + kBlockHeader), &stored,
                reinterpret_cast<const Bytef*>(plain.data()), static_cast<uLong>(plain.size()),
                1) != Z_OK) {
    throw std::runtime_error("journal " + path_ + ": cannot compress a block");
  }
  block.resize(kBlockHeader + stored);
  const auto stored32 = static_cast<std::uint32_t>(stored);
  const auto plain32 = static_cast<std::uint32_t>(plain.size());
  std::string head;
  put(head, kMagic);
  put(head, kind);
  put(head, stored32);
  put(head, plain32);
  put(head,
      block_crc(kind, stored32, plain32, std::string_view(block).substr(kBlockHeader, stored)));
  block.replace(0, kBlockHeader, head);
  for (std::size_t done = 0; done < block.size();) {
    const ssize_t n = ::write(fd_, block.data() + done, block.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) fail(path_, "cannot write");
    done += static_cast<std::size_t>(n);
  }
  if (::fdatasync(fd_) != 0) fail(path_, "cannot sync");
}

void RunJournal::remove() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  std::error_code ignored;
  fs::remove(path_, ignored);
}

JournalContents read_journal(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw config::ConfigError(path, "file", "cannot be read");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  JournalContents out;
  // Found by their paths, which the header's axes decide (a log of several
  // keeps each axis's under its group).
  std::map<std::string, log_schema::Column*, std::less<>> columns;
  const auto find_columns = [&] {
    columns.clear();
    log_schema::for_each_column(out.rows, out.axes,
                                [&](std::string_view name, log_schema::Column& c) {
                                  columns.emplace(std::string(name), &c);
                                });
  };
  find_columns();
  // A journal torn inside its first block still starts with the magic.
  const std::string magic("PZJ1");
  if (bytes.compare(0, std::min(bytes.size(), magic.size()), magic, 0,
                    std::min(bytes.size(), magic.size())) != 0) {
    throw config::ConfigError(path, "file", "not a run journal (no PZJ1 block)");
  }
  std::size_t at = 0;
  for (; at + kBlockHeader <= bytes.size(); ++out.blocks) {
    Reader head(std::string_view(bytes).substr(at, kBlockHeader));
    const auto block_magic = head.get<std::uint32_t>();
    const auto kind = head.get<std::uint8_t>();
    const auto stored = head.get<std::uint32_t>();
    const auto plain_size = head.get<std::uint32_t>();
    const auto crc = head.get<std::uint32_t>();
    if (block_magic != kMagic) break;
    if (at + kBlockHeader + stored > bytes.size()) break;
    const std::string_view payload = std::string_view(bytes).substr(at + kBlockHeader, stored);
    if (block_crc(kind, stored, plain_size, payload) != crc) break;
    std::string plain(plain_size, '\0');
    uLongf plain_len = plain_size;
    if (uncompress(reinterpret_cast<Bytef*>(plain.data()), &plain_len,
                   reinterpret_cast<const Bytef*>(payload.data()), stored) != Z_OK ||
        plain_len != plain_size) {
      break;
    }
    if (kind == kHeader) {
      read_key_values(plain, out.header);
      if (const auto axes = out.header.find(log_schema::kAxes); axes != out.header.end()) {
        out.axes = log_schema::split_axes(axes->second);
        if (out.axes.empty()) out.axes = {""};
        out.rows.assign(out.axes.size(), log_schema::LogRows{});
        find_columns();
      }
    } else if (kind == kAttribute) {
      read_key_values(plain, out.attributes);
    } else if (kind == kRows) {
      // Parsed whole before any column grows, so a bad block adds nothing.
      Reader r(plain);
      std::vector<std::pair<log_schema::Column*, std::string_view>> parts;
      while (!r.done()) {
        const std::string name = r.get_string();
        const auto n = r.get<std::uint64_t>();
        if (n > plain.size() / sizeof(double)) throw std::runtime_error("bad count");
        const std::string_view values = r.take(n * sizeof(double));
        const auto it = columns.find(name);
        if (it != columns.end()) parts.emplace_back(it->second, values);
      }
      for (auto& [column, values] : parts) {
        if (values.empty()) continue;  // memcpy wants real pointers, even for 0 bytes
        const std::size_t old = column->size();
        column->resize(old + values.size() / sizeof(double));
        std::memcpy(column->data() + old, values.data(), values.size());
      }
    }
    at += kBlockHeader + stored;
  }
  out.torn_bytes = bytes.size() - at;
  return out;
}

std::string journal_path(const std::string& log_path) {
  return (fs::path(log_path).parent_path() / "run.journal").string();
}

}  // namespace piezo::host
