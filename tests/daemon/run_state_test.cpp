// The daemon's state machine without sockets: who may do what, and what
// each way a run ends leaves latched (docs/protocol.md, "States").

#include "daemon/run_state.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include "build_paths.hpp"
#include "piezo/protocol/error.hpp"

namespace piezo::daemon {
namespace {

using firmware::StopCause;

/// The code of the ProtocolError `f` throws, or "" when it throws none.
template <class F>
std::string refusal(F&& f) {
  try {
    f();
  } catch (const protocol::ProtocolError& e) {
    return e.code();
  }
  return "";
}

TEST(RunState, IdleAnyoneMayStartAndNobodyControls) {
  RunState s;
  EXPECT_EQ(s.state(), State::idle);
  EXPECT_FALSE(s.under_way());
  EXPECT_FALSE(s.controlled());
  EXPECT_EQ(refusal([&] { s.require_can_start("a", "start"); }), "");
  EXPECT_EQ(refusal([&] { s.require_controller("b", "zero"); }), "");
}

TEST(RunState, DuringARunOnlyTheControllerIsHeardAndNobodyStartsAnother) {
  RunState s;
  s.started("a");
  EXPECT_EQ(s.state(), State::running);
  EXPECT_TRUE(s.under_way());
  EXPECT_TRUE(s.is_controller("a"));
  EXPECT_FALSE(s.is_controller("b"));
  EXPECT_EQ(refusal([&] { s.require_controller("b", "zero"); }), "not_controller");
  EXPECT_EQ(refusal([&] { s.require_controller("a", "zero"); }), "");
  EXPECT_EQ(refusal([&] { s.require_can_start("b", "start"); }), "not_controller");
  EXPECT_EQ(refusal([&] { s.require_can_start("a", "start"); }), "bad_state");
  EXPECT_EQ(refusal([&] { (void)s.reset(); }), "bad_state");
}

TEST(RunState, TheRampIsEnteredOnce) {
  RunState s;
  EXPECT_FALSE(s.ramping()) << "no run: nothing ramps";
  s.started("a");
  EXPECT_TRUE(s.ramping());
  EXPECT_EQ(s.state(), State::ramping_down);
  EXPECT_TRUE(s.under_way());
  EXPECT_FALSE(s.ramping()) << "already ramping";
}

TEST(RunState, CompletedOrInterruptedAtConfirmedZeroLeavesItIdleAndUncontrolled) {
  for (const StopCause cause : {StopCause::completed, StopCause::interrupted}) {
    RunState s;
    s.started("a");
    s.ended(cause, true);
    EXPECT_EQ(s.state(), State::idle) << firmware::to_string(cause);
    EXPECT_EQ(s.fault(), StopCause::none);
    EXPECT_FALSE(s.controlled());
    EXPECT_EQ(refusal([&] { s.require_can_start("b", "start"); }), "");
  }
}

TEST(RunState, EveryOtherCauseLatchesUntilReset) {
  for (auto c = static_cast<int>(StopCause::estop); c <= static_cast<int>(firmware::kLastStopCause);
       ++c) {
    const auto cause = static_cast<StopCause>(c);
    EXPECT_TRUE(firmware::latches(cause)) << firmware::to_string(cause);
    RunState s;
    s.started("a");
    s.ended(cause, true);
    EXPECT_EQ(s.state(), State::fault);
    EXPECT_EQ(s.fault(), cause);
    EXPECT_FALSE(s.controlled());
    EXPECT_EQ(refusal([&] { s.require_can_start("a", "move_to"); }), "fault_latched");
    EXPECT_EQ(s.reset(), cause);
    EXPECT_EQ(s.state(), State::idle);
    EXPECT_EQ(refusal([&] { s.require_can_start("b", "move_to"); }), "");
  }
  EXPECT_FALSE(firmware::latches(StopCause::none));
}

TEST(RunState, AnOutputNotConfirmedAtZeroLatchesADriveFaultWhateverTheCause) {
  RunState s;
  s.started("a");
  s.ended(StopCause::completed, false);
  EXPECT_EQ(s.state(), State::fault);
  EXPECT_EQ(s.fault(), StopCause::drive_fault);
  RunState t;
  t.started("a");
  t.ended(StopCause::link_lost, false);
  EXPECT_EQ(t.fault(), StopCause::link_lost) << "the run's own cause is the better name";
}

TEST(RunState, AnEstopAtRestLatchesAndAResetWithNothingLatchedChangesNothing) {
  RunState s;
  EXPECT_EQ(s.reset(), StopCause::none);
  EXPECT_EQ(s.state(), State::idle);
  s.estop_at_rest();
  EXPECT_EQ(s.state(), State::fault);
  EXPECT_EQ(s.fault(), StopCause::estop);
  EXPECT_EQ(refusal([&] { s.require_can_start("a", "step"); }), "fault_latched");
  EXPECT_EQ(s.reset(), StopCause::estop);
}

TEST(RunState, StatesHaveTheirProtocolNames) {
  EXPECT_EQ(to_string(State::idle), "idle");
  EXPECT_EQ(to_string(State::running), "running");
  EXPECT_EQ(to_string(State::ramping_down), "ramping_down");
  EXPECT_EQ(to_string(State::fault), "fault");
}

// docs/protocol.md's state machine names the causes that latch a fault;
// they are the ones RunState latches, every one of them.
TEST(RunState, TheCausesThatLatchAreTheOnesProtocolMdNames) {
  std::ifstream in(std::string(build_paths::source_dir) + "/docs/protocol.md");
  ASSERT_TRUE(in);
  std::stringstream page;
  page << in.rdbuf();
  const std::string text = page.str();
  const auto from = text.find("in `fault` (latched) for ");
  ASSERT_NE(from, std::string::npos) << "the state machine's latching sentence";
  const auto to = text.find(", or when", from);
  ASSERT_NE(to, std::string::npos);
  const std::string list = text.substr(from, to - from);
  std::set<std::string> documented;
  const std::regex name("`([a-z_]+)`");
  for (auto it = std::sregex_iterator(list.begin(), list.end(), name); it != std::sregex_iterator();
       ++it) {
    documented.insert((*it)[1]);
  }
  documented.erase("fault");
  std::set<std::string> latching;
  for (const auto& [cause, cause_name] : firmware::kStopCauseNames.entries()) {
    if (firmware::latches(cause)) latching.emplace(cause_name);
  }
  EXPECT_EQ(documented, latching);
}

// Every cause: where an axis's end with it latches follows its declared
// scope alone (stop_cause.hpp), the same on a board of one axis as of three.
TEST(RunState, EveryCauseLatchesWhereItsScopeSays) {
  using Latch = RunState::Latch;
  for (const auto& [cause, cause_name] : firmware::kStopCauseNames.entries()) {
    SCOPED_TRACE(std::string(cause_name));
    const Latch latch = RunState::latch_of(cause);
    switch (firmware::scope_of(cause)) {
      case firmware::CauseScope::end:
        EXPECT_EQ(latch, Latch::nowhere);
        break;
      case firmware::CauseScope::axis:
        EXPECT_EQ(latch, Latch::on_axis) << "the other axes run on";
        break;
      case firmware::CauseScope::board:
        EXPECT_EQ(latch, Latch::on_board);
        break;
    }
    // A run that ended so, on the board: latched exactly when it latches there.
    RunState s;
    s.started("a");
    s.ended(latch == Latch::on_board ? cause : StopCause::completed, true);
    EXPECT_EQ(s.state() == State::fault, latch == Latch::on_board);
  }
  // The causes docs/protocol.md calls an axis's own ("Faults on a board of
  // several") are the ones declared so.
  std::ifstream in(std::string(build_paths::source_dir) + "/docs/protocol.md");
  std::stringstream page;
  page << in.rdbuf();
  const std::string text = page.str();
  const auto from = text.find("**Faults.** An axis's own fault (");
  ASSERT_NE(from, std::string::npos);
  const std::string list = text.substr(from, text.find(')', from) - from);
  std::set<std::string> documented, own;
  const std::regex name("`([a-z_]+)`");
  for (auto it = std::sregex_iterator(list.begin(), list.end(), name); it != std::sregex_iterator();
       ++it) {
    documented.insert((*it)[1]);
  }
  for (const auto& [cause, cause_name] : firmware::kStopCauseNames.entries()) {
    if (firmware::scope_of(cause) == firmware::CauseScope::axis) own.emplace(cause_name);
  }
  EXPECT_EQ(own, documented);
}

}  // namespace
}  // namespace piezo::daemon
