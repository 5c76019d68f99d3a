#include "run_session.hpp"

#include <algorithm>

#include "board_client.hpp"
#include "board_run.hpp"
#include "io/log_schema.hpp"
#include "local_board.hpp"

namespace piezo::host {

std::string axis_end(const protocol::RunSummary::Axis& a) {
  if (a.cause == firmware::StopCause::completed && a.move && a.move->stop_cause) {
    return std::string(firmware::kMoveEndNames.name(*a.move->stop_cause));
  }
  return std::string(firmware::to_string(a.cause));
}

namespace {

bool arrived(const protocol::RunSummary::Axis& a) {
  return a.cause == firmware::StopCause::completed && a.move &&
         a.move->stop_cause == firmware::MoveEnd::on_target;
}

}  // namespace

std::string RunSummary::stop_cause() const {
  if (board_gone) return "board_gone";
  if (!host_error.empty()) return "log_failed";
  // A move, of one axis or several: the first axis that did not arrive says
  // how it ended (on_target, timeout: the board's cause is `completed` for both).
  if (is_move()) {
    for (const auto& a : board.axes)
      if (!arrived(a)) return axis_end(a);
    return axis_end(board.axes.front());
  }
  // A calibration that ran to its end but gave none the board could keep.
  if (board.cause == firmware::StopCause::completed && board.calibration.present &&
      !board.calibration.value) {
    return "calibration_unusable";
  }
  return std::string(firmware::to_string(board.cause));
}

bool RunSummary::is_move() const {
  return std::any_of(board.axes.begin(), board.axes.end(),
                     [](const protocol::RunSummary::Axis& a) { return a.move.has_value(); });
}

std::string RunSummary::output_state() const {
  // A board that fell silent never said how it left the output.
  if (board_gone) return "unknown";
  return std::string(firmware::to_string(board.output.state));
}

std::string RunSummary::status() const {
  if (!host_error.empty()) return "failed";
  if (is_move()) {
    if (std::all_of(board.axes.begin(), board.axes.end(), arrived)) return "completed";
    return board.cause == firmware::StopCause::interrupted ? "interrupted" : "failed";
  }
  switch (board.cause) {
    case firmware::StopCause::completed:
      return stop_cause() == "calibration_unusable" ? "failed" : "completed";
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
                       const std::function<void(const log_schema::AxesRows&)>& on_rows) {
  // Declared first, destroyed last: the client's sockets close before the
  // daemon's context ends.
  LocalBoard board(c, std::move(rig));
  RunSummary summary;
  {
    BoardClient client(config::BoardAddress{board.address(), "", "", 0.0, ""}, board.context());
    const protocol::Hello hello = client.hello();
    (void)axis_info(hello, c.host.board.axis, client.address());  // refused before the run
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
