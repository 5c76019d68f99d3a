// libFuzzer target: the log readers -- a run's journal, a CSV with t, V,
// theta columns, and an HDF5 file laid out by another tool (its datasets'
// names, lengths and values taken from the input, then read through
// --t/--V/--theta or as a piezo run log). A refusal (ConfigError naming the
// file and what is missing) is the expected answer; any other exception, a
// crash or a sanitizer report is a bug. libhdf5's own parser is not fuzzed
// here: the files are valid HDF5 with arbitrary contents.
// Input: byte 0 picks the reader, the rest is the file or the recipe.
#include <hdf5.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "piezo/config/config_error.hpp"
#include "io/fit_io.hpp"
#include "io/h5_file.hpp"
#include "io/run_journal.hpp"

using namespace piezo;
using namespace piezo::host;

namespace {

std::string scratch(const char* suffix) {
  return "/tmp/piezo-log-fuzz-" + std::to_string(::getpid()) + suffix;
}

void write_bytes(const std::string& path, const std::uint8_t* data, std::size_t size) {
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
}

/// An HDF5 file with up to four datasets: for each, a name from a small set
/// (so that they meet the readers' names), a length and doubles.
void write_h5(const std::string& path, const std::uint8_t* data, std::size_t size) {
  static const char* const kNames[] = {"/t",       "/V",        "/theta",        "/drive/t",
                                       "/drive/V", "/sensor/t", "/sensor/theta", "/x"};
  H5File f = H5File::create(path);
  std::size_t at = 0;
  for (int d = 0; d < 4 && at + 2 <= size; ++d) {
    const char* name = kNames[data[at] % 8];
    const std::size_t n = data[at + 1] % 64;
    at += 2;
    std::vector<double> values(n);
    for (std::size_t i = 0; i < n; ++i) {
      if (at + 8 <= size) {
        std::memcpy(&values[i], data + at, 8);
        at += 8;
      } else {
        values[i] = static_cast<double>(i) * 1e-3;
      }
    }
    if (!f.exists(name)) f.write(name, values);
  }
  if (at < size && data[at] % 2 == 1) f.set_attribute("/", "model_parameters", "{\"f\": 10");
  f.close();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::uint8_t* body = data + 1;
  const std::size_t n = size - 1;
  try {
    switch (data[0] % 4) {
      case 0:
        write_bytes(scratch(".journal"), body, n);
        (void)read_journal(scratch(".journal"));
        break;
      case 1:
        write_bytes(scratch(".csv"), body, n);
        (void)load_run_for_fit(scratch(".csv"));
        break;
      case 2:
        write_h5(scratch(".h5"), body, n);
        (void)load_run_for_fit(scratch(".h5"), LogLayout{"/t", "/V", "/theta", ""});
        break;
      default:
        write_h5(scratch(".h5"), body, n);
        (void)load_run_for_fit(scratch(".h5"));
    }
  } catch (const config::ConfigError&) {
  }
  return 0;
}
