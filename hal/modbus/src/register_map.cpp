#include "piezo/hal/modbus/register_map.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

namespace piezo::hal::modbus {
namespace {

// The 32 bits A B C D from two registers in the given order.
std::uint32_t assemble(WordOrder order, std::uint16_t w0, std::uint16_t w1) {
  auto swap_bytes = [](std::uint16_t w) { return static_cast<std::uint16_t>((w >> 8) | (w << 8)); };
  switch (order) {
    case WordOrder::ABCD:
      return (std::uint32_t{w0} << 16) | w1;
    case WordOrder::CDAB:
      return (std::uint32_t{w1} << 16) | w0;
    case WordOrder::BADC:
      return (std::uint32_t{swap_bytes(w0)} << 16) | swap_bytes(w1);
    case WordOrder::DCBA:
      return (std::uint32_t{swap_bytes(w1)} << 16) | swap_bytes(w0);
  }
  return 0;
}

void split(WordOrder order, std::uint32_t abcd, std::span<std::uint16_t> words) {
  const auto hi = static_cast<std::uint16_t>(abcd >> 16), lo = static_cast<std::uint16_t>(abcd);
  auto swap_bytes = [](std::uint16_t w) { return static_cast<std::uint16_t>((w >> 8) | (w << 8)); };
  switch (order) {
    case WordOrder::ABCD:
      words[0] = hi;
      words[1] = lo;
      break;
    case WordOrder::CDAB:
      words[0] = lo;
      words[1] = hi;
      break;
    case WordOrder::BADC:
      words[0] = swap_bytes(hi);
      words[1] = swap_bytes(lo);
      break;
    case WordOrder::DCBA:
      words[0] = swap_bytes(lo);
      words[1] = swap_bytes(hi);
      break;
  }
}

template <class Int>
Int rounded(double v) {
  const double r = std::round(v);
  return static_cast<Int>(std::clamp(r, static_cast<double>(std::numeric_limits<Int>::min()),
                                     static_cast<double>(std::numeric_limits<Int>::max())));
}

}  // namespace

int word_count(RegisterType type) {
  return type == RegisterType::u16 || type == RegisterType::s16 ? 1 : 2;
}

double decode(RegisterType type, WordOrder order, std::span<const std::uint16_t> words) {
  switch (type) {
    case RegisterType::u16:
      return words[0];
    case RegisterType::s16:
      return static_cast<std::int16_t>(words[0]);
    case RegisterType::u32:
      return assemble(order, words[0], words[1]);
    case RegisterType::s32:
      return static_cast<std::int32_t>(assemble(order, words[0], words[1]));
    case RegisterType::f32:
      return std::bit_cast<float>(assemble(order, words[0], words[1]));
  }
  return 0.0;
}

void encode(RegisterType type, WordOrder order, double value, std::span<std::uint16_t> words) {
  switch (type) {
    case RegisterType::u16:
      words[0] = rounded<std::uint16_t>(value);
      return;
    case RegisterType::s16:
      words[0] = static_cast<std::uint16_t>(rounded<std::int16_t>(value));
      return;
    case RegisterType::u32:
      split(order, rounded<std::uint32_t>(value), words);
      return;
    case RegisterType::s32:
      split(order, static_cast<std::uint32_t>(rounded<std::int32_t>(value)), words);
      return;
    case RegisterType::f32:
      split(order, std::bit_cast<std::uint32_t>(static_cast<float>(value)), words);
      return;
  }
}

std::optional<Function> parse_function(std::string_view text) {
  return kFunctionNames.parse(text);
}

std::optional<RegisterType> parse_register_type(std::string_view text) {
  return kRegisterTypeNames.parse(text);
}

std::optional<WordOrder> parse_word_order(std::string_view text) {
  return kWordOrderNames.parse(text);
}

}  // namespace piezo::hal::modbus
