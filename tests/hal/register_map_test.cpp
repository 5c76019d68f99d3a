#include "piezo/hal/modbus/register_map.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cerrno>
#include <cmath>

#include "piezo/hal/modbus/link.hpp"
#include "piezo/hal/modbus/modbus_analog_output.hpp"

namespace piezo::hal::modbus {
namespace {

TEST(RegisterDecoding, BaumerFloatInCdabOrder) {
  const std::array<std::uint16_t, 2> words{0x7C37, 0x428B};
  EXPECT_NEAR(decode(RegisterType::f32, WordOrder::CDAB, words), 69.7426, 1e-4);
  const RegisterMap baumer{Function::input, 202, RegisterType::f32, WordOrder::CDAB, 1e-3, 0.0, 1};
  EXPECT_NEAR(to_metres(baumer, words), 0.0697426, 1e-7);
}

// The same value 0x428B7C37 (bytes A B C D) in each order.
TEST(RegisterDecoding, EachWordOrderPlacesTheBytes) {
  const double expected = static_cast<double>(69.74260711669922f);
  EXPECT_DOUBLE_EQ(
      decode(RegisterType::f32, WordOrder::ABCD, std::array<std::uint16_t, 2>{0x428B, 0x7C37}),
      expected);
  EXPECT_DOUBLE_EQ(
      decode(RegisterType::f32, WordOrder::CDAB, std::array<std::uint16_t, 2>{0x7C37, 0x428B}),
      expected);
  EXPECT_DOUBLE_EQ(
      decode(RegisterType::f32, WordOrder::BADC, std::array<std::uint16_t, 2>{0x8B42, 0x377C}),
      expected);
  EXPECT_DOUBLE_EQ(
      decode(RegisterType::f32, WordOrder::DCBA, std::array<std::uint16_t, 2>{0x377C, 0x8B42}),
      expected);
}

TEST(RegisterDecoding, IntegersAndSigns) {
  EXPECT_EQ(decode(RegisterType::u16, WordOrder::ABCD, std::array<std::uint16_t, 1>{0xFFFF}),
            65535.0);
  EXPECT_EQ(decode(RegisterType::s16, WordOrder::ABCD, std::array<std::uint16_t, 1>{0xFFFF}), -1.0);
  EXPECT_EQ(
      decode(RegisterType::u32, WordOrder::ABCD, std::array<std::uint16_t, 2>{0x0001, 0x0002}),
      65538.0);
  EXPECT_EQ(
      decode(RegisterType::u32, WordOrder::CDAB, std::array<std::uint16_t, 2>{0x0002, 0x0001}),
      65538.0);
  EXPECT_EQ(
      decode(RegisterType::s32, WordOrder::ABCD, std::array<std::uint16_t, 2>{0xFFFF, 0xFFFE}),
      -2.0);
}

TEST(RegisterDecoding, RiftekCountsScaleToTheRange) {
  // RF602 with a 25 mm range: X = D * range / 16384.
  const RegisterMap rf602{
      Function::input, 0, RegisterType::s16, WordOrder::ABCD, 25e-3 / 16384, 0, 1};
  EXPECT_NEAR(to_metres(rf602, std::array<std::uint16_t, 1>{8192}), 12.5e-3, 1e-12);
}

TEST(RegisterEncoding, RoundTripsEveryTypeAndOrder) {
  for (const auto order : {WordOrder::ABCD, WordOrder::CDAB, WordOrder::BADC, WordOrder::DCBA}) {
    for (const auto& [type, value] :
         {std::pair{RegisterType::u16, 54321.0}, std::pair{RegisterType::s16, -1234.0},
          std::pair{RegisterType::u32, 3'000'000'000.0},
          std::pair{RegisterType::s32, -2'000'000'000.0}, std::pair{RegisterType::f32, 69.7426}}) {
      std::array<std::uint16_t, 2> words{};
      encode(type, order, value, words);
      EXPECT_NEAR(decode(type, order, words), value, 1e-5 * std::abs(value))
          << static_cast<int>(type) << " " << static_cast<int>(order);
    }
  }
}

TEST(LinkErrors, LibmodbusErrorsMapToStatusClasses) {
  EXPECT_EQ(Link::classify(ETIMEDOUT), Status::timeout);
  EXPECT_EQ(Link::classify(EMBBADCRC), Status::crc_error);
  EXPECT_EQ(Link::classify(EMBXSFAIL), Status::exception_reply);
  EXPECT_EQ(Link::classify(EMBXILADD), Status::exception_reply);
  EXPECT_EQ(Link::classify(ECONNRESET), Status::disconnected);
  EXPECT_EQ(Link::classify(EPIPE), Status::disconnected);
  EXPECT_EQ(Link::classify(EMBBADDATA), Status::io_error);
}

// Full scale past the 16-bit register must clamp, never wrap (65106 -> 637
// in one step would be a jump no slew limit saw).
TEST(AnalogOutputCounts, ClampToTheRegisterInsteadOfWrapping) {
  AnalogOutputSettings big;
  big.counts_per_V = 10'000;
  big.full_scale_V = 10;
  big.amplifier_gain = 20;
  EXPECT_EQ(counts_for(big, 130.2), 65'100);
  EXPECT_EQ(counts_for(big, 200.0), 65'535);
  EXPECT_EQ(counts_for(big, -5.0), 0);
  AnalogOutputSettings usual;  // 1000 counts/V, 10 V, gain 20
  EXPECT_EQ(counts_for(usual, 51.2), 2'560);
}

}  // namespace
}  // namespace piezo::hal::modbus
