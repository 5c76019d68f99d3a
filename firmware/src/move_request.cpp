#include "piezo/firmware/move_request.hpp"

#include <fmt/format.h>

#include "piezo/overload.hpp"

namespace piezo::firmware {
const MoveField* find_move_field(std::string_view name) {
  for (const MoveField& f : kMoveFields) {
    if (f.name == name) return &f;
  }
  return nullptr;
}

std::string default_text(const MoveField& field) {
  static const MoveRequest defaults;
  return std::visit(
      Overload{
          [](double MoveRequest::*m) { return fmt::format("{:g}", defaults.*m); },
          [](std::uint64_t MoveRequest::*m) { return fmt::format("{}", defaults.*m); },
          [](bool MoveRequest::*m) { return std::string(defaults.*m ? "true" : "false"); },
          [](Approach MoveRequest::*m) { return std::string(kApproachNames.name(defaults.*m)); },
      },
      field.member);
}

std::string allowed_text(const MoveField& field) {
  return std::visit(Overload{
                        [&](double MoveRequest::*) { return field.allowed.text(); },
                        [&](std::uint64_t MoveRequest::*) {
                          return fmt::format("{:g}..{:g}", field.allowed.min, field.allowed.max);
                        },
                        [](bool MoveRequest::*) { return std::string("true/false"); },
                        [](Approach MoveRequest::*) { return kApproachNames.list(); },
                    },
                    field.member);
}

}  // namespace piezo::firmware
