#pragma once
/// @file
/// A message's one field list, from which its encoder and decoder are
/// generated: each reply and event type specialises `Fields<T>` with the
/// key and member of each field, once. Keys are written there and nowhere
/// else in the codec; a member that does not exist does not compile.
///
///   template <> struct Fields<ClockReply> {
///     static constexpr auto list = std::tuple{field("board_ns", &ClockReply::board_ns)};
///   };
///
/// Values: numbers, text, flags, vectors and maps of them, nlohmann::json,
/// the enums that have `Names<E>` (by name), nested messages (a map), and
/// std::optional of any of these (nil on the wire when absent). Decoding a
/// map that lacks a field, or holds one of the wrong type, throws
/// ProtocolError (malformed, naming the field).

#include <fmt/format.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "piezo/interval.hpp"
#include "piezo/name_table.hpp"
#include "piezo/protocol/error.hpp"

namespace piezo::protocol::wire {

/// How a field travels beyond "always there, nil when absent".
enum Travel : unsigned {
  plain = 0,
  omitted_when_absent = 1,  ///< an absent optional is left out of the map (not nil)
  may_be_missing = 2,       ///< a board of an earlier revision may lack it: keep the default
};

template <class T, class M>
struct Field {
  std::string_view key;
  M T::*member;
  unsigned travel = plain;
  /// What a number (or each number of a list) may be, for `check_ranges`:
  /// its interval, whose upper end is the named limit when one is given.
  Interval allowed = {};
  std::string_view unit = {};
  std::string_view limit = {};

  [[nodiscard]] constexpr Field within(Interval i, std::string_view u,
                                       std::string_view named_limit = {}) const {
    Field f = *this;
    f.allowed = i;
    f.unit = u;
    f.limit = named_limit;
    return f;
  }
};

template <class T, class M>
constexpr Field<T, M> field(std::string_view key, M T::*member, unsigned travel = plain) {
  return {key, member, travel};
}

/// A group of fields that sit in the parent's map itself (present when its
/// first field is): `S T::*` or `std::optional<S> T::*`. An S without a
/// field list (a request) travels by its own to_json/from_json.
template <class T, class M>
struct Inline {
  M T::*member;
};

template <class T, class M>
constexpr Inline<T, M> inline_fields(M T::*member) {
  return {member};
}

/// Specialised per message type: `static constexpr auto list = std::tuple{...};`.
template <class T>
struct Fields;

/// Specialised per enum the wire carries by name: `static constexpr const auto& table`.
template <class E>
struct Names;

template <class T, class = void>
struct has_fields : std::false_type {};
template <class T>
struct has_fields<T, std::void_t<decltype(Fields<T>::list)>> : std::true_type {};

template <class T, class = void>
struct has_names : std::false_type {};
template <class T>
struct has_names<T, std::void_t<decltype(Names<T>::table)>> : std::true_type {};

template <class T>
struct is_optional : std::false_type {};
template <class T>
struct is_optional<std::optional<T>> : std::true_type {};

template <class T>
struct is_vector : std::false_type {};
template <class T>
struct is_vector<std::vector<T>> : std::true_type {};

template <class T>
struct is_text_map : std::false_type {};
template <class V>
struct is_text_map<std::map<std::string, V>> : std::true_type {};

/// A list of messages (each a map of its own fields).
template <class T>
struct is_message_list : std::false_type {};
template <class T>
struct is_message_list<std::vector<T>> : has_fields<T> {};

/// A key whose presence itself says something: a calibration run's summary
/// has `calibration`, nil when it installed none; other runs' have no key.
template <class V>
struct Keyed {
  bool present = false;
  std::optional<V> value;
};
template <class T>
struct is_keyed : std::false_type {};
template <class V>
struct is_keyed<Keyed<V>> : std::true_type {};

template <class T>
nlohmann::json encode(const T& message);
template <class T>
void decode_into(const nlohmann::json& j, T& message);

template <class V>
nlohmann::json encode_value(const V& v) {
  if constexpr (is_optional<V>::value) {
    return v ? encode_value(*v) : nlohmann::json(nullptr);
  } else if constexpr (has_fields<V>::value) {
    return encode(v);
  } else if constexpr (is_message_list<V>::value) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& item : v) out.push_back(encode(item));
    return out;
  } else if constexpr (has_names<V>::value) {
    return nlohmann::json(Names<V>::table.name(v));
  } else {
    return nlohmann::json(v);
  }
}

/// A received value as text for a message: what came in, whatever it holds
/// (a string that is not UTF-8 shows U+FFFD where its bad bytes were; a
/// plain dump() would throw on it).
inline std::string shown(const nlohmann::json& v) {
  return v.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

/// An integer field's value: an integer on the wire, or a float holding a
/// whole number (10.0 is 10), within V's range. Checked before converting:
/// a float or a negative number cast to an integer type out of its range is
/// undefined behaviour, not an error.
template <class V>
V whole_number(const nlohmann::json& v, std::string_view key) {
  const auto refuse = [&](std::string_view why) {
    return ProtocolError(code::malformed, std::string(key), fmt::format("{}: {}", key, why));
  };
  using limits = std::numeric_limits<V>;
  if (v.is_number_unsigned()) {
    const auto u = v.get<std::uint64_t>();
    if (u > static_cast<std::uint64_t>(limits::max())) throw refuse("out of range");
    return static_cast<V>(u);
  }
  if (v.is_number_integer()) {
    const auto i = v.get<std::int64_t>();
    if (std::cmp_less(i, limits::min()) || std::cmp_greater(i, limits::max())) {
      throw refuse("out of range");
    }
    return static_cast<V>(i);
  }
  if (!v.is_number_float()) throw refuse(fmt::format("of the wrong type ({})", v.type_name()));
  const double d = v.get<double>();
  // The bounds as doubles: min is exact (0 or -2^k); max + 1 is 2^k, exact.
  const double low = static_cast<double>(limits::min());
  const double past_high = 2.0 * static_cast<double>(limits::max() / 2 + 1);
  if (!(d >= low && d < past_high) || d != std::floor(d))
    throw refuse("not a whole number in range");
  return static_cast<V>(d);
}

template <class V>
V decode_value(const nlohmann::json& v, std::string_view key) {
  if constexpr (is_optional<V>::value) {
    if (v.is_null()) return std::nullopt;
    return decode_value<typename V::value_type>(v, key);
  } else if constexpr (has_fields<V>::value) {
    if (!v.is_object()) {
      throw ProtocolError(code::malformed, std::string(key), fmt::format("{}: not a map", key));
    }
    V out{};
    decode_into(v, out);
    return out;
  } else if constexpr (is_vector<V>::value) {
    if (!v.is_array()) {
      throw ProtocolError(code::malformed, std::string(key), fmt::format("{}: not a list", key));
    }
    V out;
    for (std::size_t i = 0; i < v.size(); ++i) {
      out.push_back(decode_value<typename V::value_type>(v[i], fmt::format("{}[{}]", key, i)));
    }
    return out;
  } else if constexpr (is_text_map<V>::value) {
    if (!v.is_object()) {
      throw ProtocolError(code::malformed, std::string(key), fmt::format("{}: not a map", key));
    }
    V out;
    for (const auto& [name, item] : v.items()) {
      out.emplace(name,
                  decode_value<typename V::mapped_type>(item, fmt::format("{}.{}", key, name)));
    }
    return out;
  } else if constexpr (has_names<V>::value) {
    const auto& table = Names<V>::table;
    if (v.is_string()) {
      if (const auto value = table.parse(v.get_ref<const std::string&>())) return *value;
    }
    throw ProtocolError(code::malformed, std::string(key),
                        fmt::format("{}: {}; allowed: {}", key, shown(v), table.list()));
  } else if constexpr (std::is_integral_v<V> && !std::is_same_v<V, bool>) {
    return whole_number<V>(v, key);
  } else {
    try {
      return v.get<V>();
    } catch (const nlohmann::json::exception&) {
      throw ProtocolError(code::malformed, std::string(key),
                          fmt::format("{}: of the wrong type ({})", key, v.type_name()));
    }
  }
}

template <class T, class M>
void encode_one(nlohmann::json& j, const T& message, const Field<T, M>& f) {
  const M& value = message.*(f.member);
  if constexpr (is_keyed<M>::value) {
    if (value.present) j[std::string(f.key)] = encode_value(value.value);
  } else {
    if constexpr (is_optional<M>::value) {
      if (!value && (f.travel & omitted_when_absent)) return;
    }
    j[std::string(f.key)] = encode_value(value);
  }
}

template <class T, class M>
void encode_one(nlohmann::json& j, const T& message, const Inline<T, M>& f) {
  const M& group = message.*(f.member);
  if constexpr (is_optional<M>::value) {
    if (group) j.update(encode_value(*group));
  } else {
    j.update(encode_value(group));
  }
}

template <class T, class M>
void decode_one(const nlohmann::json& j, T& message, const Field<T, M>& f) {
  const std::string key(f.key);
  const auto it = j.find(key);
  const bool absent = it == j.end() || it->is_null();
  if constexpr (is_keyed<M>::value) {
    auto& keyed = message.*(f.member);
    keyed.present = it != j.end();
    keyed.value = absent ? std::nullopt : decode_value<decltype(keyed.value)>(*it, f.key);
  } else if constexpr (std::is_same_v<M, nlohmann::json>) {
    message.*(f.member) = absent ? nlohmann::json(nullptr) : *it;
  } else if constexpr (is_optional<M>::value) {
    message.*(f.member) = absent ? std::nullopt : decode_value<M>(*it, f.key);
  } else {
    if (absent) {
      if (f.travel & may_be_missing) return;
      throw ProtocolError(code::malformed, key, fmt::format("{}: missing", key));
    }
    message.*(f.member) = decode_value<M>(*it, f.key);
  }
}

template <class T, class M>
void decode_one(const nlohmann::json& j, T& message, const Inline<T, M>& f) {
  if constexpr (is_optional<M>::value) {
    using S = typename M::value_type;
    const auto& first = std::get<0>(Fields<S>::list);
    if (!j.contains(std::string(first.key))) {
      message.*(f.member) = std::nullopt;
      return;
    }
    S group{};
    decode_into(j, group);
    message.*(f.member) = group;
  } else if constexpr (has_fields<M>::value) {
    decode_into(j, message.*(f.member));
  } else {
    message.*(f.member) = j.get<M>();  // a request: its own decoder, its own errors
  }
}

template <class T>
nlohmann::json encode(const T& message) {
  nlohmann::json j = nlohmann::json::object();
  std::apply([&](const auto&... f) { (encode_one(j, message, f), ...); }, Fields<T>::list);
  return j;
}

template <class T>
void decode_into(const nlohmann::json& j, T& message) {
  std::apply([&](const auto&... f) { (decode_one(j, message, f), ...); }, Fields<T>::list);
}

/// Where a value breaks its field's declared range: {key path, message}.
struct RangeBreach {
  std::string key, message;
};

/// Checks every field of `message` that declares a range (and each number
/// of a list, and each message of a list), its upper end the value of its
/// named limit where one is named (`limit(name)`). Keys are paths:
/// `frequencies[0].f_hz`.
template <class T, class Limit>
std::optional<RangeBreach> check_ranges(const T& message, const Limit& limit,
                                        const std::string& prefix = "") {
  std::optional<RangeBreach> breach;
  const auto check_number = [&](const std::string& key, double v, Interval allowed,
                                std::string_view unit) {
    if (breach || allowed.admits(v)) return;
    const std::string u = unit.empty() ? "" : " " + std::string(unit);
    breach = RangeBreach{key, fmt::format("{:g}{}; allowed: {}{}", v, u, allowed.text(), u)};
  };
  std::apply(
      [&](const auto&... f) {
        (
            [&](const auto& one) {
              if constexpr (requires { one.key; }) {
                const auto& value = message.*(one.member);
                using M = std::remove_cvref_t<decltype(value)>;
                const std::string key = prefix + std::string(one.key);
                Interval allowed = one.allowed;
                if (!one.limit.empty()) allowed.max = limit(one.limit);
                const bool ranged = one.allowed.min != Interval{}.min ||
                                    one.allowed.max != Interval{}.max || !one.limit.empty();
                if constexpr (std::is_arithmetic_v<M> && !std::is_same_v<M, bool>) {
                  if (ranged) check_number(key, static_cast<double>(value), allowed, one.unit);
                } else if constexpr (is_vector<M>::value) {
                  using V = typename M::value_type;
                  for (std::size_t i = 0; i < value.size() && !breach; ++i) {
                    const std::string at = fmt::format("{}[{}]", key, i);
                    if constexpr (has_fields<V>::value) {
                      breach = check_ranges(value[i], limit, at + ".");
                    } else if constexpr (std::is_arithmetic_v<V>) {
                      if (ranged)
                        check_number(at, static_cast<double>(value[i]), allowed, one.unit);
                    }
                  }
                }
              }
            }(f),
            ...);
      },
      Fields<T>::list);
  return breach;
}

/// Calls `visit(key, always)` for each key of T's own map, in the list's
/// order: its fields and those of the groups inlined in it, not the nested
/// messages'. `always`: the key is in every such map (nil when absent),
/// not left out when absent nor missing from an earlier revision's.
template <class T, class Visit>
void for_each_own_key(Visit&& visit, bool inlined = false) {
  std::apply(
      [&](const auto&... f) {
        (
            [&](const auto& one) {
              if constexpr (requires { one.key; }) {
                visit(one.key, !inlined && one.travel == plain);
              } else {
                using M = std::remove_cvref_t<decltype(std::declval<T>().*(one.member))>;
                using S = typename std::conditional_t<is_optional<M>::value, M,
                                                      std::optional<M>>::value_type;
                if constexpr (has_fields<S>::value) for_each_own_key<S>(visit, true);
              }
            }(f),
            ...);
      },
      Fields<T>::list);
}

/// Calls `visit(key)` for every key of T's list, nested ones included.
template <class T, class Visit>
void for_each_key(Visit&& visit) {
  std::apply(
      [&](const auto&... f) {
        (
            [&](const auto& one) {
              using F = std::remove_cvref_t<decltype(one)>;
              if constexpr (requires { one.key; }) {
                visit(one.key);
                using M = std::remove_cvref_t<decltype(std::declval<T>().*(one.member))>;
                using V = typename std::conditional_t<is_optional<M>::value, M,
                                                      std::optional<M>>::value_type;
                if constexpr (has_fields<V>::value) {
                  for_each_key<V>(visit);
                } else if constexpr (is_vector<V>::value) {
                  if constexpr (has_fields<typename V::value_type>::value) {
                    for_each_key<typename V::value_type>(visit);
                  }
                }
              } else {
                using M = std::remove_cvref_t<decltype(std::declval<T>().*(one.member))>;
                using S = typename std::conditional_t<is_optional<M>::value, M,
                                                      std::optional<M>>::value_type;
                if constexpr (has_fields<S>::value) for_each_key<S>(visit);
                (void)sizeof(F);
              }
            }(f),
            ...);
      },
      Fields<T>::list);
}

}  // namespace piezo::protocol::wire
