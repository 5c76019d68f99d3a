// libFuzzer target: everything piezod and its clients decode from the wire
// -- requests, replies, stream maps, sample frames and command arguments.
// A refusal (ProtocolError) is the expected answer to bad input; anything
// else (another exception, a crash, a sanitizer report) is a bug.
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "piezo/protocol/frame.hpp"
#include "piezo/protocol/message.hpp"
#include "piezo/protocol/messages.hpp"

using namespace piezo::protocol;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    switch (data[0] % 4) {
      case 0: {
        std::optional<std::uint64_t> id;
        const Request r = decode_request(bytes, id);
        // What decodes re-encodes to a request that decodes the same.
        std::optional<std::uint64_t> again;
        if (decode_request(encode_request(r), again).cmd != r.cmd || again != r.id) std::abort();
        for (const char* key : {"V0", "f", "duration_s", "lease_s"}) {
          try {
            (void)number_arg(r.args, key, 1.0);
          } catch (const ProtocolError&) {
          }
        }
        try {
          (void)uint_arg(r.args, "first", 0);
          (void)string_arg(r.args, "stream", "drive");
        } catch (const ProtocolError&) {
        }
        // The typed requests read the same arguments.
        for (int kind = 0; kind < 7; ++kind) {
          try {
            if (kind == 0) (void)decode<ConfigureRequest>(r.args);
            if (kind == 1) (void)decode<StepRequest>(r.args);
            if (kind == 2) (void)decode<MoveToRequest>(r.args);
            if (kind == 3) (void)decode<StartRequest>(r.args);
            if (kind == 4) (void)decode<CalibrateRequest>(r.args);
            if (kind == 5) (void)decode<LeaseRequest>(r.args);
            if (kind == 6) (void)decode<FetchRequest>(r.args);
          } catch (const ProtocolError&) {
          }
        }
        break;
      }
      case 1:
        (void)decode_reply(bytes);
        break;
      case 2: {
        // A map as every typed event, summary and reply (refusals expected).
        const nlohmann::json map = decode_map(bytes);
        for (int kind = 0; kind < 8; ++kind) {
          try {
            if (kind == 0) (void)decode<StateEvent>(map);
            if (kind == 1) (void)decode<HealthEvent>(map);
            if (kind == 2) (void)decode<RunSummary>(map);
            if (kind == 3) (void)decode<Hello>(map);
            if (kind == 4) (void)decode<Status>(map);
            if (kind == 5) (void)decode<StartReply>(map);
            if (kind == 6) (void)decode<MoveAccount>(map);
            if (kind == 7) (void)decode<CalibrationRecord>(map);
          } catch (const ProtocolError&) {
          }
        }
        break;
      }
      default: {
        const FrameHeader h = decode_header(bytes);
        if (h.stream == Stream::drive) {
          if (decode_drive(bytes).size() != h.count) std::abort();
        } else if (decode_sensor(bytes).size() != h.count) {
          std::abort();
        }
      }
    }
  } catch (const ProtocolError&) {
  }
  return 0;
}
