#pragma once
/// @file
/// `none` in [lines]: a rig with no lines wired (see NoLines). It has no
/// keys of its own and cannot switch the amplifier off.

#include "piezo/hal/backend.hpp"
#include "piezo/hal/posix/no_lines.hpp"

namespace piezo::hal::posix {

class NoLinesBackend final : public LinesBackend {
 public:
  [[nodiscard]] std::string_view name() const override { return "none"; }
  void read(config::SectionReader&) override {}
  [[nodiscard]] std::shared_ptr<DigitalLines> open(const LinesCommon&,
                                                   OpenContext&) const override {
    return std::make_shared<NoLines>();
  }
};

}  // namespace piezo::hal::posix
