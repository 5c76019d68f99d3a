#include "piezo/protocol/frame.hpp"

#include <fmt/format.h>

#include <bit>
#include <cstring>

#include "piezo/firmware/wire_keys.hpp"

namespace piezo::protocol {
namespace {

// Little-endian, byte by byte: the frame's layout, not the compiler's.
template <typename U>
void put(std::string& out, U value) {
  for (std::size_t i = 0; i < sizeof(U); ++i) {
    out.push_back(static_cast<char>(static_cast<std::uint8_t>(value >> (8 * i))));
  }
}

template <typename U>
U get(std::string_view in, std::size_t offset) {
  U value = 0;
  for (std::size_t i = 0; i < sizeof(U); ++i) {
    value = static_cast<U>(value |
                           (static_cast<U>(static_cast<std::uint8_t>(in[offset + i])) << (8 * i)));
  }
  return value;
}

void put_f64(std::string& out, double v) {
  put(out, std::bit_cast<std::uint64_t>(v));
}
double get_f64(std::string_view in, std::size_t offset) {
  return std::bit_cast<double>(get<std::uint64_t>(in, offset));
}
void put_i64(std::string& out, std::int64_t v) {
  put(out, static_cast<std::uint64_t>(v));
}
std::int64_t get_i64(std::string_view in, std::size_t offset) {
  return static_cast<std::int64_t>(get<std::uint64_t>(in, offset));
}

void pad(std::string& out, std::size_t n) {
  out.append(n, '\0');
}

std::string header(Stream stream, std::uint64_t first_seq, std::size_t count,
                   std::size_t record_bytes) {
  std::string out;
  out.reserve(kFrameHeaderBytes + count * record_bytes);
  out.append(kFrameMagic);
  put<std::uint16_t>(out, kFrameVersion);
  put<std::uint16_t>(out, static_cast<std::uint16_t>(stream));
  put<std::uint64_t>(out, first_seq);
  put<std::uint32_t>(out, static_cast<std::uint32_t>(count));
  put<std::uint32_t>(out, static_cast<std::uint32_t>(record_bytes));
  return out;
}

ProtocolError bad(std::string_view key, const std::string& message) {
  return {code::bad_frame, key, "sample frame: " + message};
}

std::size_t record_bytes_of(Stream s) {
  return s == Stream::drive ? kDriveRecordBytes : kSensorRecordBytes;
}

hal::Status status_from(std::uint8_t raw, const char* key) {
  if (raw > static_cast<std::uint8_t>(hal::kLastStatus)) {
    throw bad(key, fmt::format("status {} is not a known status", raw));
  }
  return static_cast<hal::Status>(raw);
}

}  // namespace

std::string_view to_string(Stream s) {
  return kStreamNames.name(s);
}

Stream stream_from_string(std::string_view name, std::string_view key) {
  if (const auto s = kStreamNames.parse(name)) return *s;
  throw ProtocolError(
      code::bad_argument, std::string(key),
      fmt::format("{}: \"{}\" is not a stream (allowed: \"drive\", \"sensor\")", key, name));
}

std::string encode_frame(std::uint64_t first_seq, std::span<const firmware::DriveSample> samples) {
  std::string out = header(Stream::drive, first_seq, samples.size(), kDriveRecordBytes);
  for (const auto& s : samples) {
    put_i64(out, s.t);
    put_f64(out, s.V);
    out.push_back(static_cast<char>(s.phase));
    out.push_back(static_cast<char>(s.status));
    out.push_back(static_cast<char>(s.move_state));
    out.push_back(static_cast<char>(s.axis));
    pad(out, 4);
  }
  return out;
}

std::string encode_frame(std::uint64_t first_seq, std::span<const firmware::SensorSample> samples) {
  std::string out = header(Stream::sensor, first_seq, samples.size(), kSensorRecordBytes);
  for (const auto& s : samples) {
    put_i64(out, s.t_request);
    put_i64(out, s.t_response);
    put_f64(out, s.displacement_m);
    out.push_back(static_cast<char>(s.status));
    out.push_back(static_cast<char>(s.axis));
    pad(out, 6);
  }
  return out;
}

FrameHeader decode_header(std::string_view frame) {
  if (frame.size() < kFrameHeaderBytes) {
    throw bad("length", fmt::format("{} bytes, shorter than the {}-byte header", frame.size(),
                                    kFrameHeaderBytes));
  }
  if (frame.substr(0, 4) != kFrameMagic) throw bad("magic", "magic is not \"PZSB\"");
  const auto version = get<std::uint16_t>(frame, 4);
  if (version != kFrameVersion) {
    throw bad(wire_key::version,
              fmt::format("version {} (this side reads version {})", version, kFrameVersion));
  }
  const auto raw_stream = get<std::uint16_t>(frame, 6);
  if (raw_stream != 1 && raw_stream != 2) {
    throw bad(wire_key::stream, fmt::format("stream {} (allowed: 1 drive, 2 sensor)", raw_stream));
  }
  FrameHeader h{static_cast<Stream>(raw_stream), get<std::uint64_t>(frame, 8),
                get<std::uint32_t>(frame, 16)};
  const auto record_bytes = get<std::uint32_t>(frame, 20);
  if (record_bytes != record_bytes_of(h.stream)) {
    throw bad("record_bytes",
              fmt::format("record size {} for the {} stream (expected {})", record_bytes,
                          to_string(h.stream), record_bytes_of(h.stream)));
  }
  const std::size_t expected = kFrameHeaderBytes + std::size_t{h.count} * record_bytes;
  if (frame.size() != expected) {
    throw bad(wire_key::count, fmt::format("{} records need {} bytes, the frame has {}", h.count,
                                           expected, frame.size()));
  }
  return h;
}

std::vector<firmware::DriveSample> decode_drive(std::string_view frame) {
  const FrameHeader h = decode_header(frame);
  if (h.stream != Stream::drive)
    throw bad(wire_key::stream, "a sensor frame where a drive frame was due");
  std::vector<firmware::DriveSample> out;
  out.reserve(h.count);
  for (std::size_t i = 0; i < h.count; ++i) {
    const std::size_t o = kFrameHeaderBytes + i * kDriveRecordBytes;
    const auto phase = static_cast<std::uint8_t>(frame[o + 16]);
    if (phase > static_cast<std::uint8_t>(firmware::DrivePhase::output_unconfirmed)) {
      throw bad("phase", fmt::format("drive phase {} is not a known phase", phase));
    }
    out.push_back(
        {get_i64(frame, o), get_f64(frame, o + 8), static_cast<firmware::DrivePhase>(phase),
         status_from(static_cast<std::uint8_t>(frame[o + 17]), "status"),
         static_cast<std::uint8_t>(frame[o + 18]), static_cast<std::uint8_t>(frame[o + 19])});
  }
  return out;
}

std::vector<firmware::SensorSample> decode_sensor(std::string_view frame) {
  const FrameHeader h = decode_header(frame);
  if (h.stream != Stream::sensor)
    throw bad(wire_key::stream, "a drive frame where a sensor frame was due");
  std::vector<firmware::SensorSample> out;
  out.reserve(h.count);
  for (std::size_t i = 0; i < h.count; ++i) {
    const std::size_t o = kFrameHeaderBytes + i * kSensorRecordBytes;
    out.push_back({get_i64(frame, o), get_i64(frame, o + 8), get_f64(frame, o + 16),
                   status_from(static_cast<std::uint8_t>(frame[o + 24]), "status"),
                   static_cast<std::uint8_t>(frame[o + 25])});
  }
  return out;
}

}  // namespace piezo::protocol
