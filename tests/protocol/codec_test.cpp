// The wire format: frames round-trip, are laid out as docs/protocol.md
// says (byte by byte, little-endian), and every malformed input is refused
// with the field named.
#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <string_view>
#include <utility>
#include <vector>

#include "piezo/protocol/frame.hpp"
#include "piezo/protocol/message.hpp"

namespace piezo::protocol {
namespace {

using firmware::DrivePhase;
using firmware::DriveSample;
using firmware::SensorSample;

TEST(Frame, DriveSamplesRoundTrip) {
  const std::vector<DriveSample> in{{1'000'000'123, 42.5, DrivePhase::driving, hal::Status::ok},
                                    {-7, -0.0, DrivePhase::stopped, hal::Status::timeout}};
  const std::string frame = encode_frame(99, in);
  EXPECT_EQ(frame.size(), kFrameHeaderBytes + 2 * kDriveRecordBytes);
  const auto h = decode_header(frame);
  EXPECT_EQ(h.stream, Stream::drive);
  EXPECT_EQ(h.first_seq, 99u);
  EXPECT_EQ(h.count, 2u);
  const auto out = decode_drive(frame);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].t, in[0].t);
  EXPECT_EQ(out[0].V, 42.5);
  EXPECT_EQ(out[1].t, -7);
  EXPECT_TRUE(std::signbit(out[1].V));
  EXPECT_EQ(out[1].phase, DrivePhase::stopped);
  EXPECT_EQ(out[1].status, hal::Status::timeout);
}

TEST(Frame, SensorSamplesRoundTrip) {
  const std::vector<SensorSample> in{{5, 6, 0.0701, hal::Status::crc_error}};
  const auto out = decode_sensor(encode_frame(3, in));
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].t_request, 5);
  EXPECT_EQ(out[0].t_response, 6);
  EXPECT_EQ(out[0].displacement_m, 0.0701);
  EXPECT_EQ(out[0].status, hal::Status::crc_error);
}

// The documented layout, checked on bytes written by hand: a peer on any
// architecture reads the same thing.
TEST(Frame, LayoutIsTheDocumentedLittleEndianOne) {
  const std::vector<DriveSample> in{
      {0x0102030405060708, 1.0, DrivePhase::ramping_down, hal::Status::io_error}};
  const std::string f = encode_frame(0x1122334455667788, in);
  EXPECT_EQ(f.substr(0, 4), "PZSB");
  EXPECT_EQ(f[4], 1);  // version, low byte first
  EXPECT_EQ(f[5], 0);
  EXPECT_EQ(f[6], 1);                                 // stream drive
  EXPECT_EQ(static_cast<unsigned char>(f[8]), 0x88);  // first_seq, low byte first
  EXPECT_EQ(static_cast<unsigned char>(f[15]), 0x11);
  EXPECT_EQ(f[16], 1);     // count
  EXPECT_EQ(f[20], 24);    // record size
  EXPECT_EQ(f[24], 0x08);  // t, low byte first
  EXPECT_EQ(f[31], 0x01);
  EXPECT_EQ(static_cast<unsigned char>(f[32 + 6]), 0xF0);  // 1.0 = 0x3FF0000000000000
  EXPECT_EQ(static_cast<unsigned char>(f[32 + 7]), 0x3F);
  EXPECT_EQ(f[40], 1);  // phase ramping_down
  EXPECT_EQ(f[41], static_cast<char>(hal::Status::io_error));
}

/// The little-endian value of the layout field `f` in `bytes` at `base`,
/// read as its declared type says (any type but text).
double read_field(const std::string& bytes, std::size_t base, const LayoutField& f) {
  const std::size_t size = static_cast<std::size_t>(f.type.back() - '0');
  std::uint64_t raw = 0;
  for (std::size_t i = 0; i < size; ++i) {
    raw |= std::uint64_t{static_cast<unsigned char>(bytes.at(base + f.offset + i))} << (8 * i);
  }
  if (f.type == "<f8") return std::bit_cast<double>(raw);
  if (f.type == "<i8") return static_cast<double>(static_cast<std::int64_t>(raw));
  return static_cast<double>(raw);
}

template <std::size_t N>
double field_named(const std::string& bytes, std::size_t base,
                   const std::array<LayoutField, N>& layout, std::string_view name) {
  for (const LayoutField& f : layout) {
    if (f.name == name) return read_field(bytes, base, f);
  }
  ADD_FAILURE() << "no field " << name;
  return std::nan("");
}

// The layout the board describes (`describe`'s `frames`, from which clients
// build their decoders) is where the encoder writes each value.
TEST(Frame, TheEncoderWritesEachValueWhereTheDescribedLayoutSays) {
  const DriveSample d{-123456789, 42.5, DrivePhase::ramping_down, hal::Status::io_error, 5};
  const std::string df = encode_frame(77, std::vector<DriveSample>{d});
  EXPECT_EQ(df.substr(0, 4), kFrameMagic);
  EXPECT_EQ(field_named(df, 0, kFrameHeaderLayout, "version"), kFrameVersion);
  EXPECT_EQ(field_named(df, 0, kFrameHeaderLayout, "stream"), 1);
  EXPECT_EQ(field_named(df, 0, kFrameHeaderLayout, "first"), 77);
  EXPECT_EQ(field_named(df, 0, kFrameHeaderLayout, "count"), 1);
  EXPECT_EQ(field_named(df, 0, kFrameHeaderLayout, "record_bytes"), kDriveRecordBytes);
  const std::size_t r = kFrameHeaderBytes;
  EXPECT_EQ(field_named(df, r, kDriveRecordLayout, "t_ns"), -123456789);
  EXPECT_EQ(field_named(df, r, kDriveRecordLayout, "V"), 42.5);
  EXPECT_EQ(field_named(df, r, kDriveRecordLayout, "phase"), static_cast<int>(d.phase));
  EXPECT_EQ(field_named(df, r, kDriveRecordLayout, "status"), static_cast<int>(d.status));
  EXPECT_EQ(field_named(df, r, kDriveRecordLayout, "move_state"), 5);
  const SensorSample s{11, -22, 3.25e-6, hal::Status::timeout};
  const std::string sf = encode_frame(0, std::vector<SensorSample>{s});
  EXPECT_EQ(field_named(sf, 0, kFrameHeaderLayout, "stream"), 2);
  EXPECT_EQ(field_named(sf, r, kSensorRecordLayout, "t_request_ns"), 11);
  EXPECT_EQ(field_named(sf, r, kSensorRecordLayout, "t_response_ns"), -22);
  EXPECT_EQ(field_named(sf, r, kSensorRecordLayout, "displacement_m"), 3.25e-6);
  EXPECT_EQ(field_named(sf, r, kSensorRecordLayout, "status"), static_cast<int>(s.status));
  // Every record field lies inside its record, without overlap.
  for (const auto& [fields, bytes] :
       {std::pair{std::vector<LayoutField>(kDriveRecordLayout.begin(), kDriveRecordLayout.end()),
                  kDriveRecordBytes},
        std::pair{std::vector<LayoutField>(kSensorRecordLayout.begin(), kSensorRecordLayout.end()),
                  kSensorRecordBytes}}) {
    std::size_t end = 0;
    for (const LayoutField& f : fields) {
      EXPECT_GE(f.offset, end) << f.name;
      end = f.offset + static_cast<std::size_t>(f.type.back() - '0');
    }
    EXPECT_LE(end, bytes);
  }
}

struct BadFrame {
  const char* name;
  std::size_t offset;  ///< byte to change (or the length to cut to, with cut)
  char value;
  bool cut;
  const char* key;
};

class MalformedFrame : public testing::TestWithParam<BadFrame> {};

TEST_P(MalformedFrame, IsRefusedNamingTheField) {
  const auto& p = GetParam();
  std::string f =
      encode_frame(1, std::vector<DriveSample>{{1, 2.0, DrivePhase::driving, hal::Status::ok}});
  if (p.cut) {
    f.resize(p.offset);
  } else {
    f[p.offset] = p.value;
  }
  try {
    (void)decode_drive(f);
    FAIL() << "accepted";
  } catch (const ProtocolError& e) {
    EXPECT_EQ(e.code(), code::bad_frame);
    EXPECT_EQ(e.key(), p.key) << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(Frame, MalformedFrame,
                         testing::Values(BadFrame{"Empty", 0, 0, true, "length"},
                                         BadFrame{"TruncatedHeader", 23, 0, true, "length"},
                                         BadFrame{"TruncatedRecord", 40, 0, true, "count"},
                                         BadFrame{"Magic", 0, 'X', false, "magic"},
                                         BadFrame{"Version", 4, 2, false, "version"},
                                         BadFrame{"Stream", 6, 9, false, "stream"},
                                         BadFrame{"RecordSize", 20, 16, false, "record_bytes"},
                                         BadFrame{"CountTooLarge", 16, 2, false, "count"},
                                         BadFrame{"Phase", 40, 9, false, "phase"},
                                         BadFrame{"Status", 41, 100, false, "status"}),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

TEST(Message, RequestRoundTrips) {
  std::optional<std::uint64_t> id;
  const auto r = decode_request(encode_request({7, "configure", {{"V0", 50.0}}}), id);
  EXPECT_EQ(id, 7u);
  EXPECT_EQ(r.cmd, "configure");
  EXPECT_EQ(number_arg(r.args, "V0"), 50.0);
}

TEST(Message, MalformedRequestsAreNamed) {
  std::optional<std::uint64_t> id;
  const auto refuse = [&](const std::string& bytes) -> ProtocolError {
    try {
      (void)decode_request(bytes, id);
    } catch (const ProtocolError& e) {
      return e;
    }
    ADD_FAILURE() << "accepted";
    return {"", "", ""};
  };
  EXPECT_EQ(refuse("\xc1").code(), code::malformed);              // never-used byte
  EXPECT_EQ(refuse("\x82\xa2id").code(), code::malformed);        // truncated map
  EXPECT_EQ(refuse(encode_map({{"cmd", "hello"}})).key(), "id");  // no id
  EXPECT_EQ(refuse(encode_map({{"id", -1}, {"cmd", "x"}})).key(), "id");
  const auto no_cmd = refuse(encode_map({{"id", 5}}));
  EXPECT_EQ(no_cmd.key(), "cmd");
  EXPECT_EQ(id, 5u);  // the error reply can still carry the id
  EXPECT_EQ(refuse(encode_map({{"id", 5}, {"cmd", 3}})).key(), "cmd");
  EXPECT_EQ(refuse(encode_map({{"id", 5}, {"cmd", "x"}, {"args", 1}})).key(), "args");
  EXPECT_EQ(refuse(std::string(kMaxMessageBytes + 1, '\x90')).code(), code::too_large);
  // Nesting that would overflow the parser's stack (found by the fuzzer).
  EXPECT_STREQ(refuse(std::string(60'000, '\x91')).what(), "nested deeper than 32 levels");
  EXPECT_THROW((void)decode_reply(std::string(60'000, '\x91')), ProtocolError);
  // A map with an integer key: malformed, but under the id read before it.
  id.reset();
  const std::string integer_key(
      "\x83\xa2"
      "id\x09\xa3"
      "cmd\xa5"
      "hello\x05\x01");
  EXPECT_EQ(refuse(integer_key).code(), code::malformed);
  EXPECT_EQ(id, 9u);
}

TEST(Message, ArgumentsOfTheWrongTypeAreNamed) {
  const nlohmann::json args{{"V0", "high"}, {"count", -3}};
  try {
    (void)number_arg(args, "V0");
    FAIL();
  } catch (const ProtocolError& e) {
    EXPECT_EQ(e.key(), "V0");
    EXPECT_STREQ(e.what(), "V0: must be a number, got string");
  }
  EXPECT_THROW((void)uint_arg(args, "count"), ProtocolError);
  EXPECT_EQ(number_arg(args, "f", 10.0), 10.0);
}

TEST(Message, ErrorReplyCarriesCodeKeyAndMessage) {
  const auto r = decode_reply(encode_error(3, {code::out_of_limits, "V0", "V0: 95 V"}));
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.id, 3u);
  EXPECT_EQ(r.error.code, "out_of_limits");
  EXPECT_EQ(r.error.key, "V0");
  const auto anonymous = decode_reply(encode_error(std::nullopt, {code::malformed, "", "x"}));
  EXPECT_FALSE(anonymous.id.has_value());
}

}  // namespace
}  // namespace piezo::protocol
