#pragma once
/// @file
/// Where a Modbus device keeps a value and how its words encode it: the
/// function, address, type and word order of a register map, with the
/// decoding done here, by hand. libmodbus 3.1.6's float helpers give wrong
/// values on little-endian hosts for some orders, so none of them is used.

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "piezo/name_table.hpp"

namespace piezo::hal::modbus {

enum class Function : std::uint8_t { holding = 3, input = 4 };
inline constexpr auto kFunctionNames =
    names<Function>({{Function::input, "input"}, {Function::holding, "holding"}});
enum class RegisterType : std::uint8_t { u16, s16, u32, s32, f32 };
inline constexpr auto kRegisterTypeNames = names<RegisterType>({{RegisterType::u16, "u16"},
                                                                {RegisterType::s16, "s16"},
                                                                {RegisterType::u32, "u32"},
                                                                {RegisterType::s32, "s32"},
                                                                {RegisterType::f32, "f32"}});
/// Byte order of a 32-bit value over its two registers, bytes A B C D from
/// most to least significant: ABCD big-endian, CDAB word-swapped, BADC
/// byte-swapped, DCBA little-endian.
enum class WordOrder : std::uint8_t { ABCD, CDAB, BADC, DCBA };
inline constexpr auto kWordOrderNames = names<WordOrder>({{WordOrder::ABCD, "ABCD"},
                                                          {WordOrder::CDAB, "CDAB"},
                                                          {WordOrder::BADC, "BADC"},
                                                          {WordOrder::DCBA, "DCBA"}});

struct RegisterMap {
  Function function = Function::input;
  int address = 0;  ///< zero-based register address (the PDU address)
  RegisterType type = RegisterType::u16;
  WordOrder order = WordOrder::ABCD;
  double scale = 1.0;   ///< metres per raw unit
  double offset = 0.0;  ///< metres added after scaling
  int unit_id = 1;
};

/// Registers a value of this type occupies (1 or 2).
[[nodiscard]] int word_count(RegisterType type);

/// The raw value held by `words` (word_count(type) registers, as read).
[[nodiscard]] double decode(RegisterType type, WordOrder order,
                            std::span<const std::uint16_t> words);
/// The inverse, for servers: writes word_count(type) registers. Integers are rounded and clamped.
void encode(RegisterType type, WordOrder order, double value, std::span<std::uint16_t> words);

/// Displacement in metres from the registers of `map`.
[[nodiscard]] inline double to_metres(const RegisterMap& map,
                                      std::span<const std::uint16_t> words) {
  return decode(map.type, map.order, words) * map.scale + map.offset;
}

[[nodiscard]] std::optional<Function> parse_function(std::string_view text);
[[nodiscard]] std::optional<RegisterType> parse_register_type(std::string_view text);
[[nodiscard]] std::optional<WordOrder> parse_word_order(std::string_view text);

}  // namespace piezo::hal::modbus
