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

#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <vector>

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
nlohmann::json encode(const T& message);
template <class T>
void decode_into(const nlohmann::json& j, T& message);

template <class V>
nlohmann::json encode_value(const V& v) {
  if constexpr (is_optional<V>::value) {
    return v ? encode_value(*v) : nlohmann::json(nullptr);
  } else if constexpr (has_fields<V>::value) {
    return encode(v);
  } else if constexpr (has_names<V>::value) {
    return nlohmann::json(Names<V>::table.name(v));
  } else {
    return nlohmann::json(v);
  }
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
  } else if constexpr (has_names<V>::value) {
    const auto& table = Names<V>::table;
    const std::string text = v.is_string() ? v.get<std::string>() : v.dump();
    if (const auto value = table.parse(text)) return *value;
    throw ProtocolError(code::malformed, std::string(key),
                        fmt::format("{}: \"{}\"; allowed: {}", key, text, table.list()));
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
  if constexpr (is_optional<M>::value) {
    if (!value && (f.travel & omitted_when_absent)) return;
  }
  j[std::string(f.key)] = encode_value(value);
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
  if constexpr (std::is_same_v<M, std::optional<nlohmann::json>>) {
    // Present (nil included) or not: a calibration run that installed none.
    message.*(f.member) = it == j.end() ? std::nullopt : std::optional(*it);
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
                if constexpr (has_fields<V>::value) for_each_key<V>(visit);
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
