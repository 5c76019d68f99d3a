#pragma once
/// @file
/// Sample batches on the wire (docs/protocol.md, "Sample frames"): a
/// versioned little-endian binary frame, the same on every architecture
/// because every field is written byte by byte, never as a struct.
///
///   offset size  field
///   0      4     magic "PZSB"
///   4      2     version (1)
///   6      2     stream (1 drive, 2 sensor)
///   8      8     first sequence number
///   16     4     count
///   20     4     record size in bytes (24 drive, 32 sensor)
///   24     ...   count records

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "piezo/firmware/samples.hpp"
#include "piezo/firmware/wire_keys.hpp"
#include "piezo/name_table.hpp"
#include "piezo/protocol/error.hpp"

namespace piezo::protocol {

inline constexpr std::string_view kFrameMagic = "PZSB";
inline constexpr std::uint16_t kFrameVersion = 1;
inline constexpr std::size_t kFrameHeaderBytes = 24;
inline constexpr std::size_t kDriveRecordBytes = 24;
inline constexpr std::size_t kSensorRecordBytes = 32;

/// One field of the header or of a record as the wire lays it out: its
/// name, its type in numpy's notation ("<i8": little-endian 8-byte
/// integer; "S4": 4 bytes of text) and its offset. The board describes the
/// layout from these (`describe`'s `frames`), so a client builds its
/// decoder from the board; codec_test holds the encoder to them.
struct LayoutField {
  std::string_view name, type;
  std::size_t offset;
};
inline constexpr std::array<LayoutField, 6> kFrameHeaderLayout{{{"magic", "S4", 0},
                                                                {wire_key::version, "<u2", 4},
                                                                {wire_key::stream, "<u2", 6},
                                                                {wire_key::first, "<u8", 8},
                                                                {wire_key::count, "<u4", 16},
                                                                {"record_bytes", "<u4", 20}}};
/// A record's `axis` is the board's axis it belongs to (its index in
/// hello.axes): 0 on a board of one, where the byte was padding before.
inline constexpr std::array<LayoutField, 6> kDriveRecordLayout{{{"t_ns", "<i8", 0},
                                                                {"V", "<f8", 8},
                                                                {"phase", "u1", 16},
                                                                {"status", "u1", 17},
                                                                {"move_state", "u1", 18},
                                                                {wire_key::axis, "u1", 19}}};
inline constexpr std::array<LayoutField, 5> kSensorRecordLayout{{{"t_request_ns", "<i8", 0},
                                                                 {"t_response_ns", "<i8", 8},
                                                                 {"displacement_m", "<f8", 16},
                                                                 {"status", "u1", 24},
                                                                 {wire_key::axis, "u1", 25}}};

enum class Stream : std::uint16_t { drive = 1, sensor = 2 };
inline constexpr auto kStreamNames =
    names<Stream>({{Stream::drive, "drive"}, {Stream::sensor, "sensor"}});

[[nodiscard]] std::string_view to_string(Stream s);
/// "drive" or "sensor"; throws ProtocolError (bad_argument, key) otherwise.
[[nodiscard]] Stream stream_from_string(std::string_view name, std::string_view key);

struct FrameHeader {
  Stream stream = Stream::drive;
  std::uint64_t first_seq = 0;
  std::uint32_t count = 0;
};

[[nodiscard]] std::string encode_frame(std::uint64_t first_seq,
                                       std::span<const firmware::DriveSample> samples);
[[nodiscard]] std::string encode_frame(std::uint64_t first_seq,
                                       std::span<const firmware::SensorSample> samples);

/// Checks magic, version, stream, record size and length; throws
/// ProtocolError ("bad_frame") naming the field that is wrong.
[[nodiscard]] FrameHeader decode_header(std::string_view frame);
[[nodiscard]] std::vector<firmware::DriveSample> decode_drive(std::string_view frame);
[[nodiscard]] std::vector<firmware::SensorSample> decode_sensor(std::string_view frame);

}  // namespace piezo::protocol
