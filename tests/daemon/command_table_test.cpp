// piezod's command table without sockets: what dispatch refuses before a
// handler runs (an unknown command, an argument the command does not take,
// a caller the command does not admit during another client's run), and
// that it hands everything else to the handler as sent.

#include "daemon/command_table.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "piezo/protocol/error.hpp"

namespace piezo::daemon {
namespace {

using nlohmann::json;

struct Table {
  int handled = 0;
  json last_args;
  CommandTable table{{
      {"watch",
       Caller::anyone,
       {},
       [this](const std::string&, const json& a) {
         ++handled;
         last_args = a;
         return json("watched");
       }},
      {"change",
       Caller::controller,
       {protocol::spec_of(firmware::arguments::V0),
        protocol::spec_of(firmware::arguments::lease_s)},
       [this](const std::string&, const json& a) {
         ++handled;
         last_args = a;
         return json("changed");
       }},
      {"estop",
       Caller::anyone,
       {},
       [this](const std::string&, const json&) {
         ++handled;
         return json("stopped");
       }},
  }, "b0a4d"};
};

/// "code key" of the ProtocolError `f` throws, or "" when it throws none.
template <class F>
std::string refusal(F&& f) {
  try {
    f();
  } catch (const protocol::ProtocolError& e) {
    return e.code() + " " + e.key();
  }
  return "";
}

TEST(CommandTable, AnUnknownCommandIsRefusedListingThemAll) {
  Table t;
  RunState s;
  try {
    (void)t.table.dispatch("a", "chnage", json::object(), s);
    FAIL() << "accepted";
  } catch (const protocol::ProtocolError& e) {
    EXPECT_EQ(e.code(), "unknown_command");
    EXPECT_EQ(e.key(), "cmd");
    EXPECT_NE(std::string(e.what()).find("allowed: watch, change, estop"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(t.handled, 0);
}

TEST(CommandTable, AnArgumentTheCommandDoesNotTakeIsRefusedBeforeTheHandler) {
  Table t;
  RunState s;
  EXPECT_EQ(refusal([&] {
              (void)t.table.dispatch("a", "change", {{"V_0", 1}}, s);
            }),
            "bad_argument V_0");
  EXPECT_EQ(t.handled, 0);
  EXPECT_EQ(t.table.dispatch("a", "change", {{"V0", 1}}, s), "changed");
  EXPECT_EQ(t.last_args, json({{"V0", 1}}));
}

TEST(CommandTable, DuringAnotherClientsRunOnlyAnyonesCommandsAreServed) {
  Table t;
  RunState s;
  s.started("a");
  EXPECT_EQ(refusal([&] { (void)t.table.dispatch("b", "change", json::object(), s); }),
            "not_controller ");
  EXPECT_EQ(t.table.dispatch("b", "watch", json::object(), s), "watched");
  EXPECT_EQ(t.table.dispatch("a", "change", json::object(), s), "changed");
  EXPECT_EQ(t.handled, 2);
}

TEST(CommandTable, ARequestNamingAnotherBoardStartIsRefusedBeforeAnythingElse) {
  Table t;
  RunState s;
  s.started("a");
  // Even the controller's own request, and before its caller is judged.
  EXPECT_EQ(refusal([&] { (void)t.table.dispatch("a", "change", {{"board", "0ld"}}, s); }),
            "stale_board board");
  EXPECT_EQ(refusal([&] { (void)t.table.dispatch("b", "watch", {{"board", "0ld"}}, s); }),
            "stale_board board");
  EXPECT_EQ(refusal([&] { (void)t.table.dispatch("a", "change", {{"board", 7}}, s); }),
            "bad_argument board");
  EXPECT_EQ(t.handled, 0);
  EXPECT_EQ(t.table.dispatch("a", "change", {{"board", "b0a4d"}, {"V0", 1}}, s), "changed");
  EXPECT_EQ(t.table.dispatch("a", "change", {{"V0", 1}}, s), "changed") << "board is optional";
}

TEST(CommandTable, AnEstopNamesNoBoardStartAndIsNeverRefusedForOne) {
  Table t;
  RunState s;
  EXPECT_EQ(t.table.dispatch("b", "estop", json::object(), s), "stopped");
  EXPECT_EQ(refusal([&] { (void)t.table.dispatch("b", "estop", {{"board", "0ld"}}, s); }),
            "bad_argument board")
      << "estop takes no board: an e-stop is honoured whoever sent it";
  for (const auto& spec : t.table.specs()) {
    const bool takes_board = std::any_of(spec.args.begin(), spec.args.end(),
                                         [](const auto& a) { return a.name == "board"; });
    EXPECT_EQ(takes_board, spec.name != "estop") << spec.name;
  }
}

}  // namespace
}  // namespace piezo::daemon
