#include "run_session.hpp"

#include "board_client.hpp"
#include "board_run.hpp"
#include "io/log_schema.hpp"
#include "local_board.hpp"

namespace piezo::host {

std::string RunSummary::stop_cause() const {
  if (board_gone) return "board_gone";
  if (!host_error.empty()) return "log_failed";
  // A move that ended by itself says how: on_target, or timeout (the board's
  // cause is `completed` for both).
  if (board.cause == firmware::StopCause::completed && board.move && board.move->stop_cause) {
    return std::string(firmware::kMoveEndNames.name(*board.move->stop_cause));
  }
  // A calibration that ran to its end but gave none the board could keep.
  if (board.cause == firmware::StopCause::completed && board.calibration.present &&
      !board.calibration.value) {
    return "calibration_unusable";
  }
  return std::string(firmware::to_string(board.cause));
}

std::string RunSummary::output_state() const {
  // A board that fell silent never said how it left the output.
  if (board_gone) return "unknown";
  return std::string(firmware::to_string(board.output.state));
}

std::string RunSummary::status() const {
  if (!host_error.empty()) return "failed";
  switch (board.cause) {
    case firmware::StopCause::completed:
      return stop_cause() == "timeout" || stop_cause() == "calibration_unusable" ? "failed"
                                                                                 : "completed";
    case firmware::StopCause::interrupted:
      return "interrupted";
    default:
      return "failed";
  }
}

RunSummary execute_run(const config::ConfigFile& c, const RunAsked& asked, config::Rig rig,
                       RunLog& log, const std::atomic<bool>& stop,
                       const std::function<void(const LiveStatus&)>& on_status,
                       const std::atomic<bool>* estop,
                       const std::function<void(const log_schema::LogRows&)>& on_rows) {
  // Declared first, destroyed last: the client's sockets close before the
  // daemon's context ends.
  LocalBoard board(c, std::move(rig));
  RunSummary summary;
  {
    BoardClient client(config::BoardAddress{board.address(), "", "", 0.0, ""}, board.context());
    const protocol::Hello hello = axis_view(client.hello(), c.host.board.axis, client.address());
    const BoardRequest request = board_request(c.host, asked);
    prepare_request(request, client);
    summary = run_on_board(c, client, hello, log, stop, on_status, request, estop, on_rows);
  }
  board.stop();
  try {
    log.set_attribute(log_schema::kBoardEvents, board.events());
  } catch (const std::exception&) {
    // a log that failed already says why in the summary
  }
  return summary;
}

}  // namespace piezo::host
