#pragma once
/// @file
/// The GPIO backends on libgpiod: a parallel DAC on a chip's lines as the
/// drive (`gpiod-dac`, [drive.gpiod-dac]) and the rig's enable, sync and
/// e-stop lines (`gpiod`, [lines.gpiod]).

#include "piezo/hal/backend.hpp"
#include "piezo/hal/gpiod/gpiod_rig.hpp"

namespace piezo::hal::gpiod {

class ParallelDacBackend final : public DriveBackend {
 public:
  [[nodiscard]] std::string_view name() const override { return "gpiod-dac"; }
  [[nodiscard]] std::vector<MovedKey> moved_keys() const override;
  [[nodiscard]] std::vector<Claim> claims() const override;
  void read(config::SectionReader& section) override;
  void check(const DriveCommon& common, bool chosen, const SourceOf& source) const override;
  [[nodiscard]] std::shared_ptr<Drive> open(const DriveCommon& common,
                                            OpenContext& context) const override;

  /// The lines and the DAC's scaling at [drive]'s amplifier gain.
  [[nodiscard]] GpiodDacSettings settings(const DriveCommon& common) const;

 private:
  GpiodDacSettings settings_;
};

class RigLinesBackend final : public LinesBackend {
 public:
  [[nodiscard]] std::string_view name() const override { return "gpiod"; }
  [[nodiscard]] std::vector<MovedKey> moved_keys() const override;
  void read(config::SectionReader& section) override;
  void check(const LinesCommon& common, bool chosen, const SourceOf& source) const override;
  [[nodiscard]] std::shared_ptr<DigitalLines> open(const LinesCommon& common,
                                                   OpenContext& context) const override;

  [[nodiscard]] const GpiodLinesSettings& settings() const { return settings_; }

 private:
  GpiodLinesSettings settings_;
};

}  // namespace piezo::hal::gpiod
