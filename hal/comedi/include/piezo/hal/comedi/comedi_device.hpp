#pragma once
/// @file
/// One DAQ card opened through comedilib, and what the backends ask of it:
/// a subdevice checked against the config (its kind, clocked streams, the
/// channel and the range, refused naming the key and what the card has), the
/// card's calibration for a channel, and a listing for the wiring check.

#include <comedilib.h>

#include <string>

namespace piezo::hal::comedi {

/// Where a signal is on a card, as a config names it.
struct ChannelAddress {
  std::string device = "/dev/comedi0";
  int subdevice = -1;  ///< -1: the card's first subdevice of the kind
  int channel = 0;
  int range = 0;  ///< the card's range index (`piezo sensor list` shows them)
};

/// What a subdevice must be.
struct SubdeviceKind {
  int type;            ///< COMEDI_SUBD_AO, COMEDI_SUBD_AI, COMEDI_SUBD_DO, ...
  int flags;           ///< flags it must have, e.g. SDF_CMD_WRITE for a clocked output
  const char* what;    ///< "a clocked analog output", for messages
  int also_type = -1;  ///< a second type that does as well (COMEDI_SUBD_DIO for a DO)
  [[nodiscard]] bool has_type(int t) const { return t == type || t == also_type; }
  [[nodiscard]] bool analog() const { return type == COMEDI_SUBD_AI || type == COMEDI_SUBD_AO; }
};

/// The config's names for a signal's keys, under a section such as
/// "drive.comedi": what a refusal names.
struct AddressKeys {
  std::string section;
  std::string subdevice = "subdevice";
  std::string channel = "channel";
  std::string range = "range";
};

class ComediDevice {
 public:
  /// Opens the card; throws std::runtime_error naming the device.
  explicit ComediDevice(const std::string& path);
  ~ComediDevice();
  ComediDevice(const ComediDevice&) = delete;
  ComediDevice& operator=(const ComediDevice&) = delete;

  [[nodiscard]] comedi_t* get() const { return dev_; }
  [[nodiscard]] const std::string& path() const { return path_; }
  /// Lets go of the handle and opens the card again by its path: for a
  /// handle that no longer reaches the card (closed under the process, the
  /// card re-enumerated). False when the card cannot be opened; get() is
  /// then null.
  bool reopen();

  /// The subdevice `address` names, checked for `kind`, its channel and (an
  /// analog one's) range. Throws config::ConfigError naming the subdevice,
  /// channel or range key with what the card has.
  [[nodiscard]] unsigned checked_subdevice(const ChannelAddress& address, const SubdeviceKind& kind,
                                           const AddressKeys& keys) const;
  /// The card's calibration for one channel and range: comedi_soft_calibrate's
  /// file where the card has one, else the driver's own (hardware-calibrated
  /// cards, and the test driver).
  [[nodiscard]] comedi_polynomial_t converter(unsigned subdevice, unsigned channel, unsigned range,
                                              comedi_conversion_direction direction) const;
  /// The card's subdevices, channels and ranges, one per line.
  [[nodiscard]] std::string describe() const;

  /// "comedi_command: Invalid argument", from comedilib's last error.
  [[nodiscard]] static std::string last_error(const std::string& call);

 private:
  std::string path_;
  comedi_t* dev_ = nullptr;
};

}  // namespace piezo::hal::comedi
