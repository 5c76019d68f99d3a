#pragma once
/// @file
/// A request's codec generated from its arguments: a request type whose
/// `RequestFields<T>` lists each declared argument (request_arguments.hpp)
/// with the member that holds it is encoded and decoded by the templates
/// here, with the argument readers' errors (bad_argument, naming the
/// argument). An optional member is left out when absent; any other is
/// required.

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <tuple>
#include <type_traits>

#include "piezo/firmware/request_arguments.hpp"
#include "piezo/protocol/frame.hpp"
#include "piezo/protocol/message.hpp"

namespace piezo::protocol {

template <class T, class M>
struct ArgumentField {
  firmware::Argument argument;
  M T::*member;
};

template <class T, class M>
constexpr ArgumentField<T, M> argument_field(const firmware::Argument& a, M T::*member) {
  return {a, member};
}

/// Specialised per request with a generated codec: `static constexpr auto list = std::tuple{...};`.
template <class T>
struct RequestFields;

template <class T>
concept FieldRequest = requires {
  RequestFields<T>::list;
};

/// The arguments a request takes: its `kArgs`, or its fields' arguments.
template <class T>
constexpr auto arguments_of() {
  if constexpr (FieldRequest<T>) {
    return std::apply(
        [](const auto&... f) {
          return std::array<firmware::Argument, sizeof...(f)>{f.argument...};
        },
        RequestFields<T>::list);
  } else {
    return T::kArgs;
  }
}

namespace request_fields {

template <class V>
nlohmann::json wire_value(const V& v) {
  if constexpr (std::is_same_v<V, Stream>) {
    return nlohmann::json(to_string(v));
  } else {
    return nlohmann::json(v);
  }
}

template <class V>
V read_value(const nlohmann::json& args, const std::string& key) {
  if constexpr (std::is_same_v<V, double>) {
    return number_arg(args, key);
  } else if constexpr (std::is_same_v<V, std::uint64_t>) {
    return uint_arg(args, key);
  } else if constexpr (std::is_same_v<V, bool>) {
    return bool_arg(args, key);
  } else if constexpr (std::is_same_v<V, Stream>) {
    return stream_from_string(string_arg(args, key), key);
  } else {
    return string_arg(args, key);
  }
}

template <class M>
struct optional_of {
  using type = void;
};
template <class V>
struct optional_of<std::optional<V>> {
  using type = V;
};

}  // namespace request_fields

template <FieldRequest T>
void to_json(nlohmann::json& j, const T& m) {
  j = nlohmann::json::object();
  std::apply(
      [&](const auto&... f) {
        (
            [&](const auto& one) {
              const auto& value = m.*(one.member);
              const std::string key(one.argument.name);
              using M = std::remove_cvref_t<decltype(value)>;
              if constexpr (!std::is_void_v<typename request_fields::optional_of<M>::type>) {
                if (value) j[key] = request_fields::wire_value(*value);
              } else {
                j[key] = request_fields::wire_value(value);
              }
            }(f),
            ...);
      },
      RequestFields<T>::list);
}

template <FieldRequest T>
void from_json(const nlohmann::json& j, T& m) {
  std::apply(
      [&](const auto&... f) {
        (
            [&](const auto& one) {
              auto& value = m.*(one.member);
              const std::string key(one.argument.name);
              using M = std::remove_cvref_t<decltype(value)>;
              using V = typename request_fields::optional_of<M>::type;
              if constexpr (!std::is_void_v<V>) {
                const auto it = j.find(key);
                value = it == j.end() || it->is_null()
                            ? std::nullopt
                            : std::optional<V>(request_fields::read_value<V>(j, key));
              } else {
                value = request_fields::read_value<M>(j, key);
              }
            }(f),
            ...);
      },
      RequestFields<T>::list);
}

}  // namespace piezo::protocol
