// The host's board client against piezod as its own process: a request it
// gave up on never reaches a board that comes back later, and a request
// meant for a board start that is gone is refused without moving anything.
// What the board did is read from the board itself (its run, its request
// counts) through a client of its own.
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <thread>

#include "piezo/protocol/error.hpp"
#include "rig_sim.hpp"
#include "run/board_client.hpp"

namespace piezo::testing {
namespace {

using namespace std::chrono_literals;

class BoardComesBack : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fresh_temp_dir("board-identity");
    port_ = free_port(2);
    address_ = "tcp://127.0.0.1:" + std::to_string(port_);
  }
  void start_board() {
    board_ = std::make_unique<Spawned>(
        std::vector<std::string>{build_paths::piezod, "--config",
                                 std::string(build_paths::source_dir) + "/configs/piezod-sim.toml",
                                 "--listen", address_},
        (dir_ / ("piezod-" + std::to_string(++starts_) + ".log")).string());
    ASSERT_TRUE(wait_for_tcp(port_));
  }
  void kill_board() {
    board_->signal(SIGKILL);
    (void)board_->wait_exit();
  }
  [[nodiscard]] config::BoardAddress rig() const {
    config::BoardAddress a;
    a.address = address_;
    return a;
  }
  /// The board's status, asked by a client that has sent nothing else.
  [[nodiscard]] nlohmann::json fresh_status() const {
    host::BoardClient watcher(rig());
    return watcher.call("status", nlohmann::json::object(), 5s);
  }

  fs::path dir_;
  int port_ = 0, starts_ = 0;
  std::string address_;
  std::unique_ptr<Spawned> board_;
};

const nlohmann::json kMove = {{"target_rad", 0.005}};

TEST_F(BoardComesBack, AMoveTheClientGaveUpOnNeverRunsOnTheBoardThatComesBack) {
  start_board();
  host::BoardClient client(rig());
  const std::string first = client.hello().board_id;
  EXPECT_FALSE(first.empty());
  kill_board();
  EXPECT_THROW((void)client.call("move_to", kMove, 1000ms), host::LinkTimeout);
  client.send("lease", {{"drive_received", 0}});  // a renewal sent blind, as a run's are

  start_board();
  std::this_thread::sleep_for(5s);  // ZeroMQ reconnects within its 2 s back-off
  const nlohmann::json status = fresh_status();
  EXPECT_NE(status.at("board_id"), first) << "a restarted board has a new identity";
  EXPECT_EQ(status.at("state"), "idle");
  EXPECT_FALSE(status.contains("run")) << status.dump();
  EXPECT_EQ(status.at("requests").at("move_to"), 0) << status.at("requests").dump();
  EXPECT_EQ(status.at("requests").at("hello"), 0) << status.at("requests").dump();

  // The same client's next request names the board start it knew: refused,
  // nothing moved, and the client is told why.
  try {
    (void)client.call("move_to", kMove, 5000ms);
    FAIL() << "a move for the old board start was taken";
  } catch (const host::RemoteError& e) {
    EXPECT_EQ(e.code(), "stale_board");
    EXPECT_EQ(e.key(), "board");
  }
  const nlohmann::json after = fresh_status();
  EXPECT_FALSE(after.contains("run")) << after.dump();
  // The lease renewal sent blind reached the new board (ZeroMQ kept it: no
  // reply was awaited) and was refused for its board, not taken.
  EXPECT_EQ(after.at("state"), "idle");

  // Asked again, the client knows the new board and is served.
  EXPECT_EQ(client.hello().board_id, after.at("board_id"));
  EXPECT_EQ(client.call("status").at("board_id"), after.at("board_id"));
}

TEST_F(BoardComesBack, AClientThatGaveUpOnceStaysTheController) {
  // The client's socket is reopened after a timeout under the same routing
  // id: the board hands the connection over, so a run's controller is
  // still its controller (its stop is taken, not refused not_controller).
  start_board();
  host::BoardClient client(rig());
  (void)client.hello();
  (void)client.call("move_to", {{"target_rad", 1.0}, {"lease_s", 5.0}, {"timeout_s", 60.0}});
  // A reply that cannot come in time: the socket is dropped and reopened.
  EXPECT_THROW((void)client.call("status", nlohmann::json::object(), 0ms), host::LinkTimeout);
  const nlohmann::json stopped = client.call("stop", nlohmann::json::object(), 5000ms);
  EXPECT_TRUE(stopped.contains("state")) << stopped.dump();
  ASSERT_TRUE(poll_until([&] { return fresh_status().at("state") == "idle"; }, 20s));
  EXPECT_EQ(fresh_status().at("run").at("summary").at("cause"), "interrupted");
}

}  // namespace
}  // namespace piezo::testing
